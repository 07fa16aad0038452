//! A camera fault injected from a ground station in flight: pymavlink (tests/python/
//! gcs_camera_fault.py) flies `config/sim-forest.toml`'s graph over the textured wall of
//! `config/worlds/wall-textured.toml` in GUIDED and, 10 m short of the wall, sends
//! MAV_CMD_INJECT_FAILURE on the avoidance unit (glare over the middle of both images). The
//! simulator puts the glare on its schedule, the camera applies it from the `sim_fault` start,
//! the stereo actor names it (`camera_blind: glare`) and gives no depth grid, the commander holds
//! and then lands (`avoidance_lost`, LAND). The client asserts each on what it receives: the
//! ACK, both STATUSTEXTs, the LAND mode, the landing and disarm short of the wall.

mod support;
use support::{flights, sim_vehicle};

use flights::{repo, sim_forest_graph};
use sim_vehicle::{scripted_session, temp_dir};

#[test]
fn glare_injected_mid_leg_is_named_and_the_vehicle_holds_then_lands_short_of_the_wall() {
    let dir = temp_dir("camera-fault");
    let world = repo().join("config/worlds/wall-textured.toml");
    let started = std::time::Instant::now();
    let result = scripted_session(&dir, "camera-fault", "gcs_camera_fault.py", &[], |port| {
        let graph = sim_forest_graph(&world);
        let endpoints = "params.endpoints = [{ type = \"udp_in\", bind = \"127.0.0.1:0\" }]";
        assert!(graph.contains(endpoints), "the flight graph's link as flights.rs makes it");
        graph.replace(
            endpoints,
            &format!(
                "params.system_id = 1\nparams.endpoints = [{{ type = \"udp_out\", address = \"127.0.0.1:{port}\" }}]"
            ),
        )
    });
    let flown = &result["results"]["camera_fault"];
    println!("figure: glare injected in flight: {flown} ({:.1} s wall)", started.elapsed().as_secs_f64());
    let landed = flown["landed_north_m"].as_f64().expect("landed_north_m");
    assert!(landed < 19.0, "{flown}");
    std::fs::remove_dir_all(&dir).ok();
}
