//! Offboard body velocity (SET_POSITION_TARGET_LOCAL_NED in MAV_FRAME_BODY_NED, as MAVSDK's
//! `set_velocity_body` and companion computers send it) against ArduCopter SITL and `kestrel run`:
//! the one pymavlink script tests/python/gcs_offboard.py flies both (the ArduCopter half when
//! `KESTREL_ARDUCOPTER` names the binary, see tests/support/arducopter.rs), and the test compares
//! what each reported.
//!
//! What ArduCopter 4.7 does (`handle_message_set_position_target_local_ned`, `ModeGuided`): a body
//! velocity is turned by the heading, so the vehicle flies where its nose points; a stream that
//! stops is flown on for GUID_TIMEOUT (3 s) and then stopped; a yaw rate alone turns the nose;
//! a type mask it does not fly (a position and an acceleration without a velocity) stops the
//! vehicle at once. Kestrel does the same; both are held to the same bounds and to each other.

mod support;
use support::{arducopter, sim_vehicle};

use std::time::Instant;

use serde_json::Value;
use sim_vehicle::{scripted_session, session_link, sim_config, temp_dir};

const SCRIPT: &str = "gcs_offboard.py";

fn num(r: &Value, part: &str, field: &str) -> f64 {
    r["results"][part][field].as_f64().unwrap_or_else(|| panic!("no {part}.{field} in {r:#}"))
}

/// What either stack must report.
fn assert_offboard(stack: &str, r: &Value) {
    let bearing = num(r, "forward", "bearing_error_deg");
    assert!(bearing.abs() < 15.0, "{stack}: flew {bearing}° off the nose: {r:#}");
    let distance = num(r, "forward", "distance_m");
    assert!((7.0..=14.0).contains(&distance), "{stack}: {distance} m in 6 s at 2 m/s: {r:#}");
    let flew_on = num(r, "timeout", "flew_on_s");
    assert!(
        (2.5..=6.0).contains(&flew_on),
        "{stack}: stopped {flew_on} s after the stream, not after GUID_TIMEOUT (3 s): {r:#}"
    );
    let turned = num(r, "yaw_rate", "turned_deg");
    assert!((80.0..=150.0).contains(&turned), "{stack}: turned {turned}° in 4 s at 0.5 rad/s (115°): {r:#}");
    let stopped = num(r, "bad_mask", "stopped_s");
    assert!(stopped < 2.5, "{stack}: a mask it does not fly stopped it only after {stopped} s: {r:#}");
}

#[test]
fn offboard_body_velocity_flies_as_arducopter_flies_it() {
    let started = Instant::now();
    let dir = temp_dir("offboard");
    let kestrel =
        scripted_session(&dir, "offboard", SCRIPT, &[], |port| sim_config(&session_link(port, &dir)));
    assert_offboard("kestrel", &kestrel);
    println!("kestrel half: {:.1} s: {}", started.elapsed().as_secs_f64(), kestrel["results"]);

    let Some(binary) = arducopter::binary() else { return };
    let sitl_started = Instant::now();
    let ardu = arducopter::scripted_session(&binary, SCRIPT, &[]);
    println!("ArduCopter half: {:.1} s: {}", sitl_started.elapsed().as_secs_f64(), ardu["results"]);
    assert_offboard("arducopter", &ardu);
    let (ours, theirs) = (num(&kestrel, "timeout", "flew_on_s"), num(&ardu, "timeout", "flew_on_s"));
    assert!(
        (ours - theirs).abs() <= 1.5,
        "flown on after the stream: kestrel {ours} s, ArduCopter {theirs} s"
    );
    let (ours, theirs) = (num(&kestrel, "yaw_rate", "turned_deg"), num(&ardu, "yaw_rate", "turned_deg"));
    assert!((ours - theirs).abs() <= 30.0, "turned: kestrel {ours}°, ArduCopter {theirs}°");
    let _ = std::fs::remove_dir_all(&dir);
    println!("whole test: {:.1} s", started.elapsed().as_secs_f64());
}
