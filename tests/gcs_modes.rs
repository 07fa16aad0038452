//! CIRCLE, DO_ORBIT, BRAKE, reboot and motor test as a ground station asks for them, by one
//! pymavlink script, tests/python/gcs_modes.py, against `kestrel run` and ArduCopter SITL (when
//! `KESTREL_ARDUCOPTER` names it, see tests/support/arducopter.rs); the test compares the ACKs
//! and the modes each showed.
//!
//! What ArduCopter 4.7 does (SITL on `copter.parm`, the script's transcript): in the air, reboot
//! and motor test are FAILED; DO_ORBIT is UNSUPPORTED (Copter has no handler for it); mode
//! CIRCLE (7) and BRAKE (17) are ACCEPTED and shown, and with the sticks centred its CIRCLE flies
//! a 9.7 m circle at 19.8 °/s (Kestrel's: 10.1 m at 20.0 °/s, on its estimator's positions);
//! disarmed on the ground the motor test is ACCEPTED ("starting motor test").
//!
//! Kestrel differs on purpose in two answers, each asserted: DO_ORBIT is ACCEPTED and flown in
//! CIRCLE (MAVSDK's `action.do_orbit` and QGroundControl's Orbit must circle, as PX4 does); and
//! a refusal is DENIED where ArduCopter says FAILED (the link answers every commander refusal
//! DENIED). The disarmed motor test is ACCEPTED by both (what it spins:
//! tests/gcs_reboot_motor_test.rs).

mod support;
use support::{arducopter, sim_vehicle};

use std::time::Instant;

use serde_json::Value;
use sim_vehicle::{scripted_session, session_link, sim_config, temp_dir};

const SCRIPT: &str = "gcs_modes.py";

fn results(v: &Value) -> &Value {
    let r = &v["results"];
    assert!(r.is_object(), "no results in {v:#}");
    r
}

fn ack<'a>(r: &'a Value, step: &str) -> &'a str {
    r["acks"][step].as_str().unwrap_or_else(|| panic!("no ACK for {step}: {r:#}"))
}

/// What both stacks must show: CIRCLE and BRAKE taken and shown, reboot and motor test refused
/// in the air, a circle flown.
fn assert_common(stack: &str, r: &Value) {
    for step in ["mode_circle", "mode_brake"] {
        assert_eq!(ack(r, step), "MAV_RESULT_ACCEPTED", "{stack}: {step}: {r:#}");
    }
    assert_eq!(r["modes"]["after_mode_circle"], "CIRCLE", "{stack}: {r:#}");
    assert_eq!(r["modes"]["after_mode_brake"], "BRAKE", "{stack}: {r:#}");
    for step in ["reboot_armed", "motor_test_armed"] {
        let a = ack(r, step);
        assert!(a == "MAV_RESULT_FAILED" || a == "MAV_RESULT_DENIED", "{stack}: {step} answered {a}: {r:#}");
    }
    assert_eq!(r["modes"]["after_reboot_and_motor_test"], "GUIDED", "{stack}: the refusals changed nothing");
    let circle = &r["circle"];
    let radius = circle["radius_m"].as_f64().unwrap_or_else(|| panic!("{stack}: no circle: {r:#}"));
    let rms = circle["rms_m"].as_f64().expect("rms");
    assert!((radius - 10.0).abs() < 1.0 && rms < 0.5, "{stack}: CIRCLE flew {circle}");
    let brake = r["brake_speed_m_s"].as_f64().unwrap_or_else(|| panic!("{stack}: no speed after BRAKE"));
    assert!(brake < 0.3, "{stack}: {brake} m/s after BRAKE");
}

#[test]
fn circle_orbit_brake_reboot_and_motor_test_answer_as_arducopter_does() {
    let started = Instant::now();
    let dir = temp_dir("modes");
    let kestrel = scripted_session(&dir, "modes", SCRIPT, &[], |port| sim_config(&session_link(port, &dir)));
    let ours = results(&kestrel);
    assert_common("kestrel", ours);
    assert_eq!(ack(ours, "do_orbit"), "MAV_RESULT_ACCEPTED", "{ours:#}");
    assert_eq!(ours["modes"]["after_do_orbit"], "CIRCLE", "DO_ORBIT flies in CIRCLE: {ours:#}");
    assert_eq!(ack(ours, "motor_test_disarmed"), "MAV_RESULT_ACCEPTED", "{ours:#}");
    let rate = ours["circle"]["rate_deg_s"].as_f64().expect("rate");
    assert!((rate - 20.0).abs() < 2.0, "CIRCLE_RATE_DEGS 20, flown {rate} deg/s");
    println!("kestrel half: {:.1} s: {}", started.elapsed().as_secs_f64(), ours);

    let Some(binary) = arducopter::binary() else { return };
    let sitl_started = Instant::now();
    let ardu = arducopter::scripted_session(&binary, SCRIPT, &[]);
    println!("ArduCopter half: {:.1} s", sitl_started.elapsed().as_secs_f64());
    let theirs = results(&ardu);
    assert_common("arducopter", theirs);
    println!("ArduCopter: {theirs}");
    // The differences on purpose (module docs).
    assert_eq!(ack(theirs, "do_orbit"), "MAV_RESULT_UNSUPPORTED", "ArduCopter 4.7 has no DO_ORBIT");
    for step in ["mode_circle", "mode_brake", "motor_test_disarmed"] {
        assert_eq!(ack(ours, step), ack(theirs, step), "{step}");
    }
    // The same circle on the same defaults (CIRCLE_RADIUS 10 m, CIRCLE_RATE 20 °/s).
    let rate = |r: &Value| r["circle"]["rate_deg_s"].as_f64().expect("rate");
    let radius = |r: &Value| r["circle"]["radius_m"].as_f64().expect("radius");
    assert!(
        (rate(ours) - rate(theirs)).abs() < 1.0,
        "rates: kestrel {}, ArduCopter {}",
        rate(ours),
        rate(theirs)
    );
    assert!(
        (radius(ours) - radius(theirs)).abs() < 1.0,
        "radii: kestrel {}, ArduCopter {}",
        radius(ours),
        radius(theirs)
    );
    let _ = std::fs::remove_dir_all(&dir);
    println!("whole test: {:.1} s", started.elapsed().as_secs_f64());
}
