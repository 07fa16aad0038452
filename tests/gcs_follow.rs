//! FOLLOW as a ground station asks for it, by one pymavlink script, tests/python/gcs_follow.py,
//! against `kestrel run` and ArduCopter SITL (when `KESTREL_ARDUCOPTER` names it, see
//! tests/support/arducopter.rs): FOLLOW refused while `FOLL_ENABLE` is 0, then, enabled, a
//! target that sends FOLLOW_TARGET (position and velocity) walks north at 3 m/s for 15 s 5 m
//! ahead of the vehicle and stops; its reports stop. The test compares the ACKs, the modes and
//! what each flew.
//!
//! Kestrel differs on purpose in one answer, asserted: FOLLOW without `FOLL_ENABLE` is DENIED
//! where ArduCopter says FAILED (the link answers every commander refusal DENIED); both say
//! "Set FOLL_ENABLE = 1".

mod support;
use support::{arducopter, sim_vehicle};

use std::time::Instant;

use serde_json::Value;
use sim_vehicle::{scripted_session, session_link, sim_config, temp_dir};

const SCRIPT: &str = "gcs_follow.py";

fn results(v: &Value) -> &Value {
    let r = &v["results"];
    assert!(r.is_object(), "no results in {v:#}");
    r
}

fn num(r: &Value, key: &str) -> f64 {
    r["follow"][key].as_f64().unwrap_or_else(|| panic!("no follow.{key}: {r:#}"))
}

/// What both stacks must show: refused without FOLL_ENABLE with ArduCopter's text, then FOLLOW
/// taken and kept, the vehicle keeping its place behind the walking target and stopping with it,
/// then holding once the reports stop.
fn assert_common(stack: &str, r: &Value) {
    let refused = r["acks"]["follow_disabled"].as_str().unwrap_or("NONE");
    assert!(refused == "MAV_RESULT_FAILED" || refused == "MAV_RESULT_DENIED", "{stack}: {r:#}");
    assert!(
        r["texts"].as_array().is_some_and(|t| t.iter().any(|t| t.as_str() == Some("Set FOLL_ENABLE = 1"))),
        "{stack}: {r:#}"
    );
    assert_eq!(r["modes"]["after_follow_disabled"], "GUIDED", "{stack}: {r:#}");
    assert_eq!(r["acks"]["follow"], "MAV_RESULT_ACCEPTED", "{stack}: {r:#}");
    for after in ["after_follow", "after_walk", "after_lost"] {
        assert_eq!(r["modes"][after], "FOLLOW", "{stack}: {after}: {r:#}");
    }
    assert!(num(r, "flown_m") > 40.0, "{stack}: flew {} m of the target's 45 m", num(r, "flown_m"));
    assert!(num(r, "final_m") < 1.5, "{stack}: stopped {} m from its place", num(r, "final_m"));
    assert!(num(r, "side_m") < 1.5 && num(r, "height_m") < 1.5, "{stack}: {r:#}");
    let lost = r["lost_speed_m_s"].as_f64().unwrap_or_else(|| panic!("{stack}: no speed after the loss"));
    assert!(lost < 0.3, "{stack}: {lost} m/s after the reports stopped");
}

#[test]
fn follow_refused_until_enabled_then_keeps_its_place_behind_a_walking_target_as_arducopter_does() {
    let started = Instant::now();
    let dir = temp_dir("follow");
    let kestrel = scripted_session(&dir, "follow", SCRIPT, &[], |port| sim_config(&session_link(port, &dir)));
    let ours = results(&kestrel);
    assert_common("kestrel", ours);
    assert_eq!(ours["acks"]["follow_disabled"], "MAV_RESULT_DENIED", "{ours:#}");
    println!("kestrel half: {:.1} s: {}", started.elapsed().as_secs_f64(), ours);

    let Some(binary) = arducopter::binary() else { return };
    let sitl_started = Instant::now();
    let ardu = arducopter::scripted_session(&binary, SCRIPT, &[]);
    println!("ArduCopter half: {:.1} s", sitl_started.elapsed().as_secs_f64());
    let theirs = results(&ardu);
    println!("ArduCopter: {theirs}");
    assert_common("arducopter", theirs);
}
