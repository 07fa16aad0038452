//! A camera that keeps delivering frames but no longer sees, flown closed loop in lockstep with
//! the simulator's camera faults: glare over the middle of the image 10 m before the textured
//! wall, and the right lens capped mid-leg in the forest. Each time the stereo actor names the
//! fault in its `sensor_health` (what the link sends as STATUSTEXT), gives no depth grid, the
//! commander holds on the stale avoidance input and then lands where it holds
//! (`avoidance_lost`), and nothing is hit. The two flights run side by side.

mod support;
use support::{flights, qgc_plan};

use std::path::{Path, PathBuf};

use flights::{clearance_m, collisions, repo, run_for_report, scratch, sim_forest_graph};
use kestrel::recorder::LogReader;
use kestrel_proto::messages::{GroundTruth, SensorHealth};
use qgc_plan::Item;
use serde_json::Value;

/// When the glare starts (s of simulated time): the vehicle is then about 10 m short of the wall
/// at 20 m north, flying at about 4.5 m/s (checked on the recorded ground truth).
const GLARE_AT_S: f64 = 8.7;
/// When the right lens is capped (s of simulated time): some 15 m north, among the forest's
/// first trees (from 12 m).
const CAP_AT_S: f64 = 12.0;

/// What one flight left: its report, the faults the stereo actor's health reports named with the
/// first time each was named (s), and the ground truth north of home at `probe_s` (m).
struct Flown {
    report: Value,
    named: Vec<(String, f64)>,
    north_at_probe_m: f64,
}

/// Flies `plan` in `world` with `config/sim-forest.toml`'s graph for at most 90 s, recording it.
fn fly(name: &str, world: &str, plan: impl FnOnce(&Path) -> PathBuf, probe_s: f64) -> Flown {
    let dir = scratch("blind", name);
    let world_path = dir.join("world.toml");
    std::fs::write(&world_path, world).unwrap();
    let config = dir.join("graph.toml");
    std::fs::write(&config, sim_forest_graph(&world_path)).unwrap();
    let plan = plan(&dir);
    let log = dir.join("flight.mcap");
    let report = run_for_report(
        name,
        &config,
        &[
            "--auto",
            "--exit-on-land",
            "--duration",
            "90",
            "--mission",
            &plan.display().to_string(),
            "--record",
            &log.display().to_string(),
        ],
    );
    let reader = LogReader::open(&log).unwrap();
    let mut named: Vec<(String, f64)> = Vec::new();
    for r in reader.read::<SensorHealth>("sensor_health").unwrap() {
        let h = r.message;
        if h.sensor == "stereo" && h.errors > 0 && !named.iter().any(|(d, _)| *d == h.device) {
            named.push((h.device, h.time.as_secs_f64()));
        }
    }
    let truth = reader.read::<GroundTruth>("ground_truth").unwrap();
    let north_at_probe_m = truth
        .iter()
        .find(|r| r.message.time.as_secs_f64() >= probe_s)
        .map(|r| r.message.position_ned_m[0])
        .expect("ground truth at the probe time");
    let _ = std::fs::remove_dir_all(&dir);
    let flight = &report["flight"];
    println!(
        "figure: {name}: collisions {}, min clearance {:.2} m, landed {}, {:.1} s, failsafes {}, north {:.1} m at {probe_s} s, named {named:?}",
        flight["collisions"],
        flight["min_clearance_m"].as_f64().unwrap_or(f64::NAN),
        flight["landed"],
        flight["duration_s"].as_f64().unwrap_or(f64::NAN),
        report["failsafes"],
        north_at_probe_m,
    );
    Flown { report, named, north_at_probe_m }
}

/// The `(cause, action)` of each failsafe in the report.
fn failsafes(report: &Value) -> Vec<(String, String)> {
    report["failsafes"]
        .as_array()
        .expect("failsafes")
        .iter()
        .map(|f| {
            (f["cause"].as_str().expect("cause").to_owned(), f["action"].as_str().expect("action").to_owned())
        })
        .collect()
}

fn glare_flight() -> Flown {
    let stock = std::fs::read_to_string(repo().join("config/worlds/wall-textured.toml")).unwrap();
    let world = format!(
        "{stock}\n[[faults]]\nat_s = {GLARE_AT_S:.1}\nkind = \"camera_glare\"\n\
         region = [0.2, 0.2, 0.8, 0.8]\nintensity = 1.0\nlens = \"both\"\n"
    );
    fly("glare-wall", &world, |dir| qgc_plan::leg(dir, 0.0, 40.0, 6.0), GLARE_AT_S)
}

fn capped_flight() -> Flown {
    let forest = std::fs::read_to_string(repo().join("config/worlds/forest.toml")).unwrap();
    let clear = "keep_clear_m = [[0.0, 0.0], [100.0, 0.0]]";
    assert!(forest.contains(clear) && forest.contains("\nseed = 1\n"), "the forest as the test knows it");
    // Seed 1 with its landing spot moved to the leg's end, 40 m north: no tree stands on it.
    let world = format!(
        "{}\n[[faults]]\nat_s = {CAP_AT_S:.1}\nkind = \"camera_capped\"\nlens = \"right\"\n",
        forest.replace(clear, "keep_clear_m = [[0.0, 0.0], [40.0, 0.0]]")
    );
    let plan = |dir: &Path| {
        qgc_plan::write(
            dir,
            "forest-leg.plan",
            &[
                Item::north(qgc_plan::TAKEOFF, 0.0, 5.0),
                Item::north(qgc_plan::WAYPOINT, 40.0, 5.0),
                Item::north(qgc_plan::LAND, 40.0, 0.0),
            ],
        )
    };
    fly("capped-forest", &world, plan, CAP_AT_S)
}

#[test]
fn glare_before_the_wall_and_a_capped_lens_in_the_forest_are_named_held_and_landed_without_collision() {
    let (glare, capped) = std::thread::scope(|scope| {
        let glare = scope.spawn(glare_flight);
        let capped = scope.spawn(capped_flight);
        (glare.join().unwrap(), capped.join().unwrap())
    });
    for (flown, fault, at_s) in [
        (&glare, "stereo camera: camera_blind: glare", GLARE_AT_S),
        (&capped, "stereo camera: lens_capped: right", CAP_AT_S),
    ] {
        let report = &flown.report;
        assert_eq!(collisions(report), 0, "{report:#}");
        assert!(clearance_m(report) > 0.3, "{report:#}");
        assert_eq!(report["flight"]["landed"], true, "{report:#}");
        assert_eq!(report["mission"]["completed"], false, "the leg is not flown blind: {report:#}");
        assert_eq!(failsafes(report), [("avoidance_lost".to_owned(), "land".to_owned())], "{report:#}");
        // Named by the first health report after the fault, and nothing else named.
        assert_eq!(flown.named.len(), 1, "{:?}", flown.named);
        assert_eq!(flown.named[0].0, fault);
        assert!((at_s..at_s + 1.5).contains(&flown.named[0].1), "{:?}", flown.named);
    }
    assert!(
        (9.0..=11.0).contains(&glare.north_at_probe_m),
        "the glare starts 10 m short of the wall at 20 m: {} m north",
        glare.north_at_probe_m
    );
    // Holding, then landing, short of the wall.
    assert!(clearance_m(&glare.report) > 2.0, "{:#}", glare.report);
}
