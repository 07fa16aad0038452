//! Rally points and RTL: one pymavlink script, tests/python/gcs_rally.py, reads RALLY_LIMIT_KM
//! and RALLY_INCL_HOME, uploads a rally plan holding a waypoint and then two rally points, takes
//! off in GUIDED, flies 60 m north and switches to RTL; run against `kestrel run` and ArduCopter
//! SITL (when `KESTREL_ARDUCOPTER` names it, see tests/support/arducopter.rs), and the test
//! compares what each reported.
//!
//! What ArduCopter 4.7 does (SITL on `copter.parm`, the script's transcript): RALLY_LIMIT_KM
//! 0.3 and RALLY_INCL_HOME 1; the waypoint in a rally plan is refused MAV_MISSION_UNSUPPORTED;
//! the two rally points are ACCEPTED and download as sent; take-off, DO_REPOSITION and the
//! switch to RTL are ACCEPTED; from 60 m north the nearest rally point (R1, 40 m north, 15 m up)
//! is 20 m away and home 60 m, so RTL climbs to 15 m (RTL_ALT and R1's altitude), flies to R1,
//! lands there (3 cm from it) and disarms. R2, 400 m east, is never a candidate.

mod support;
use support::{arducopter, sim_vehicle};

use std::time::Instant;

use serde_json::{Value, json};
use sim_vehicle::{scripted_session, session_link, sim_config, temp_dir};

const SCRIPT: &str = "gcs_rally.py";
/// How far from the rally point either stack may come down (m): the acceptance the brief of
/// this test sets, a landing controller's drift in still air being well inside it.
const LANDING_TOLERANCE_M: f64 = 2.0;
/// R1 is 40 m from home (m), and the return is flown at 15 m, give or take the position
/// controller's overshoot at the top of the climb.
const R1_FROM_HOME_M: f64 = 40.0;
const RETURN_ALT_M: f64 = 15.0;

fn results(v: &Value) -> &Value {
    let r = &v["results"];
    assert!(r.is_object(), "no results in {v:#}");
    r
}

fn metres(r: &Value, path: [&str; 2]) -> f64 {
    r[path[0]][path[1]].as_f64().unwrap_or_else(|| panic!("no {path:?} in {r:#}"))
}

/// What either stack must report.
fn assert_as_arducopter(stack: &str, r: &Value) {
    assert_eq!(
        r["acks"],
        json!({
            "waypoint_in_rally": "MAV_MISSION_UNSUPPORTED",
            "rally_upload": "MAV_MISSION_ACCEPTED",
            "takeoff": "MAV_RESULT_ACCEPTED",
            "reposition": "MAV_RESULT_ACCEPTED",
            "rtl": "MAV_RESULT_ACCEPTED",
        }),
        "{stack}: ACKs"
    );
    // As sent: R1 40 m north at 15 m, R2 400 m east at 20 m (1e-7 degree, metres).
    assert_eq!(
        r["downloaded"],
        json!([[67974593, 799017000, 15.0], [67971000, 799053187, 20.0]]),
        "{stack}: rally points downloaded"
    );
    assert_eq!(r["params"], json!({"RALLY_LIMIT_KM": 0.30000001192092896, "RALLY_INCL_HOME": 1.0}));
    let from_r1 = metres(r, ["rtl_from_m", "r1"]);
    assert!((from_r1 - 20.0).abs() < 2.0, "{stack}: RTL began {from_r1} m from R1: {r:#}");
    let landed_r1 = metres(r, ["landed", "r1"]);
    assert!(landed_r1 <= LANDING_TOLERANCE_M, "{stack}: landed {landed_r1} m from the rally point: {r:#}");
    let landed_home = metres(r, ["landed", "home"]);
    assert!(
        (landed_home - R1_FROM_HOME_M).abs() <= LANDING_TOLERANCE_M,
        "{stack}: {landed_home} m from home"
    );
    let top = r["max_alt_m"].as_f64().expect("max_alt_m");
    assert!((top - RETURN_ALT_M).abs() <= 1.5, "{stack}: returned at up to {top} m, not {RETURN_ALT_M}");
    assert_eq!(r["modes"].as_array().and_then(|m| m.last()), Some(&json!("RTL")), "{stack}: {r:#}");
}

#[test]
fn rtl_lands_at_the_nearest_rally_point_as_arducopter() {
    let started = Instant::now();
    let dir = temp_dir("rally");
    let kestrel = scripted_session(&dir, "rally", SCRIPT, &[], |port| sim_config(&session_link(port, &dir)));
    let ours = results(&kestrel);
    assert_as_arducopter("kestrel", ours);
    println!("kestrel half: {:.1} s", started.elapsed().as_secs_f64());

    let Some(binary) = arducopter::binary() else { return };
    let sitl_started = Instant::now();
    let ardu = arducopter::scripted_session(&binary, SCRIPT, &[]);
    println!("ArduCopter half: {:.1} s", sitl_started.elapsed().as_secs_f64());
    let theirs = results(&ardu);
    assert_as_arducopter("arducopter", theirs);
    for key in ["params", "acks", "downloaded"] {
        assert_eq!(ours[key], theirs[key], "{key}: kestrel against ArduCopter");
    }
    println!(
        "landed from R1: kestrel {} m, ArduCopter {} m; highest on the return: kestrel {} m, ArduCopter {} m",
        ours["landed"]["r1"], theirs["landed"]["r1"], ours["max_alt_m"], theirs["max_alt_m"]
    );
    let _ = std::fs::remove_dir_all(&dir);
    println!("whole test: {:.1} s", started.elapsed().as_secs_f64());
}
