//! A geofence from the ground station: one pymavlink script, tests/python/gcs_fence.py, sets
//! the FENCE_* parameters, uploads two malformed fences and then an inclusion square with an
//! exclusion circle, takes off in GUIDED, asks for targets beyond the fence (outside the
//! square, inside the circle, above the FENCE_ALT_MAX ceiling) and flies a leg across the
//! circle; run against `kestrel run` and ArduCopter SITL (when `KESTREL_ARDUCOPTER` names it,
//! see tests/support/arducopter.rs), and the test compares what each reported.
//!
//! What ArduCopter 4.7 does (SITL on `copter.parm`, the script's transcript): AUTOPILOT_VERSION
//! claims MISSION_FENCE; each PARAM_SET echoes its value; a polygon of 2 vertices and vertices
//! whose counts differ are each refused MAV_MISSION_ERROR (with "Invalid vertex count (2)" and
//! "Unexpected vertex count" in words); the good fence is ACCEPTED and downloads as 5 items;
//! each DO_REPOSITION beyond the fence is FAILED and the vehicle stays put; the leg across the
//! circle is ACCEPTED and breaches at the circle's edge (about 35 m north): RTL, FENCE_STATUS
//! breached, 1 breach, BOUNDARY; once out of the circle, "Fence breach cleared", FENCE_STATUS
//! back to 0 with the count kept, still in RTL (about 10 s after the breach: the RTL's mode
//! change started a manual recovery, "Manual recovery started", in which nothing changes).
//! Then: FENCE_TOTAL reads 7 (4 vertices, 1 circle, +2); an RTL from 6 m under FENCE_ALT_MAX 14
//! climbs to 12.0 m (RTL_ALT 15 capped at the ceiling less FENCE_MARGIN 2); the ceiling lowered
//! to 10 m under a vehicle at 12 m breaches it (MAXALT, RTL) and the RTL keeps its altitude;
//! MAV_CMD_DO_LAND_START is FAILED with no DO_LAND_START in the mission ("Mode change to AUTO
//! RTL failed: No landing sequence found"), then ACCEPTED with one ("Landing sequence start"):
//! the mission goes on from the item after it, in mode AUTO_RTL (27). Kestrel reports that mode
//! as AUTO (3): it has no AUTO RTL mode of its own, so the mode is not compared.

mod support;
use support::{arducopter, sim_vehicle};

use std::time::Instant;

use serde_json::{Value, json};
use sim_vehicle::{scripted_session, session_link, sim_config, temp_dir};

const SCRIPT: &str = "gcs_fence.py";
/// Where the leg enters the exclusion circle (m north of home: 50 m less its 15 m radius), and
/// how far from it either stack may notice: FENCE_STATUS at 4 Hz of a vehicle doing up to 10 m/s.
const CIRCLE_EDGE_M: f64 = 35.0;
const EDGE_TOLERANCE_M: f64 = 6.0;
/// RTL_ALT (15 m on both) capped by FENCE_ALT_MAX 14 less FENCE_MARGIN 2.
const RTL_CAP_M: f64 = 12.0;

fn results(v: &Value) -> &Value {
    let r = &v["results"];
    assert!(r.is_object(), "no results in {v:#}");
    r
}

/// What either stack must report.
fn assert_as_arducopter(stack: &str, r: &Value) {
    assert_eq!(r["fence_capability"], true, "{stack}: AUTOPILOT_VERSION without MISSION_FENCE");
    assert_eq!(
        r["params"],
        json!({"FENCE_ENABLE": 1.0, "FENCE_TYPE": 7.0, "FENCE_ALT_MAX": 40.0, "FENCE_RADIUS": 300.0, "FENCE_ACTION": 1.0}),
        "{stack}: PARAM_SET echoes"
    );
    assert_eq!(
        r["malformed"],
        json!({"two_vertices": "MAV_MISSION_ERROR", "counts_differ": "MAV_MISSION_ERROR"}),
        "{stack}: malformed fences"
    );
    assert_eq!(r["upload"], json!({"ack": "MAV_MISSION_ACCEPTED", "count": 5}), "{stack}: the fence");
    assert_eq!(
        r["targets"],
        json!({
            "outside_polygon": "MAV_RESULT_FAILED",
            "inside_exclusion": "MAV_RESULT_FAILED",
            "above_ceiling": "MAV_RESULT_FAILED",
            "across_exclusion": "MAV_RESULT_ACCEPTED",
        }),
        "{stack}: targets"
    );
    let moved = r["moved_m"].as_f64().expect("moved_m");
    assert!(moved < 2.0, "{stack}: moved {moved} m after refused targets");
    let breach = &r["breach"];
    assert_eq!(
        (&breach["mode"], &breach["status"], &breach["count"], &breach["type"]),
        (&json!("RTL"), &json!(1), &json!(1), &json!("FENCE_BREACH_BOUNDARY")),
        "{stack}: breach {breach}"
    );
    let at = breach["north_m"].as_f64().expect("north_m");
    assert!((at - CIRCLE_EDGE_M).abs() <= EDGE_TOLERANCE_M, "{stack}: breached {at} m from home");
    assert_eq!(
        r["cleared"],
        json!({"status": 0, "count": 1, "type": "FENCE_BREACH_NONE", "mode": "RTL", "text": true}),
        "{stack}: recovery"
    );
    assert_eq!(r["fence_total"], json!(7.0), "{stack}: FENCE_TOTAL of 4 vertices and a circle");
    let peak = r["rtl_capped"]["peak_m"].as_f64().expect("peak_m");
    assert!(
        (RTL_CAP_M - 1.0..=RTL_CAP_M + 1.0).contains(&peak),
        "{stack}: RTL under a 14 m ceiling flew up to {peak} m"
    );
    assert_eq!(
        r["rtl_from_above"],
        json!({"mode": "RTL", "type": "FENCE_BREACH_MAXALT", "kept_altitude": true}),
        "{stack}: RTL from above the ceiling"
    );
    let land_start = &r["land_start"];
    assert_eq!(
        (&land_start["no_sequence"], &land_start["ack"], &land_start["first_leg_flown"], &land_start["text"]),
        (&json!("MAV_RESULT_FAILED"), &json!("MAV_RESULT_ACCEPTED"), &json!(false), &json!(true)),
        "{stack}: DO_LAND_START {land_start}"
    );
}

#[test]
fn an_uploaded_fence_refuses_targets_and_its_breach_returns_as_arducopter() {
    let started = Instant::now();
    let dir = temp_dir("fence");
    let kestrel = scripted_session(&dir, "fence", SCRIPT, &[], |port| sim_config(&session_link(port, &dir)));
    let ours = results(&kestrel);
    assert_as_arducopter("kestrel", ours);
    println!("kestrel half: {:.1} s", started.elapsed().as_secs_f64());

    let Some(binary) = arducopter::binary() else { return };
    let sitl_started = Instant::now();
    let ardu = arducopter::scripted_session(&binary, SCRIPT, &[]);
    println!("ArduCopter half: {:.1} s", sitl_started.elapsed().as_secs_f64());
    let theirs = results(&ardu);
    assert_as_arducopter("arducopter", theirs);
    for key in [
        "fence_capability",
        "params",
        "malformed",
        "upload",
        "targets",
        "cleared",
        "fence_total",
        "rtl_from_above",
    ] {
        assert_eq!(ours[key], theirs[key], "{key}: kestrel against ArduCopter");
    }
    let _ = std::fs::remove_dir_all(&dir);
    println!("whole test: {:.1} s", started.elapsed().as_secs_f64());
}
