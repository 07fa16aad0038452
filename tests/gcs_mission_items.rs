//! Survey and DO_JUMP missions as ground stations send them: one pymavlink script,
//! tests/python/gcs_mission_items.py, against `kestrel run` and ArduCopter SITL (when
//! `KESTREL_ARDUCOPTER` names it, see tests/support/arducopter.rs); the test compares what each
//! answered and flew.
//!
//! What ArduCopter 4.7 does (SITL on `copter.parm`, the script's transcript): CONDITION_GATE is
//! refused (UNSUPPORTED), a DO_JUMP to home or past the last item is refused (ERROR), a gimbal
//! item with NaN rates is refused (INVALID_PARAM3); every other survey, scan and MAVSDK item is
//! ACCEPTED, and so is QGroundControl's survey (config/missions/survey.plan) with its camera
//! triggers. The jump mission (take-off, A, B, jump to A once, C, land) is flown
//! A B A B C: MISSION_ITEM_REACHED 1 2 3 2 3 5, MISSION_CURRENT 1 2 3 2 3 5 6; after the
//! landing it disarms and makes item 1 current again (its mission restarts at the next AUTO).
//!
//! Kestrel answers and flies the same, with two differences the test pins rather than hides:
//! Kestrel sends MISSION_ITEM_REACHED for the LAND item when it has landed (ArduCopter sends
//! none for it), and keeps the finished mission's last item current after the landing.

mod support;
use support::{arducopter, sim_vehicle};

use std::time::Instant;

use serde_json::Value;
use sim_vehicle::{scripted_session, session_link, sim_config, temp_dir};

const SCRIPT: &str = "gcs_mission_items.py";

fn results(v: &Value) -> &Value {
    let r = &v["results"];
    assert!(r.is_object(), "no results in {v:#}");
    r
}

/// The MISSION_CURRENT sequence from the first waypoint (item 2) to the landing item (6): the
/// take-off item was flown in GUIDED, and what each says before AUTO and after the landing is
/// not compared (see the module's doc).
fn flown(r: &Value) -> Vec<u64> {
    let currents: Vec<u64> =
        r["jump"]["currents"].as_array().expect("currents").iter().filter_map(Value::as_u64).collect();
    let start = currents.iter().position(|&s| s == 2).unwrap_or(0);
    let end = currents.iter().position(|&s| s == 6).map_or(currents.len(), |i| i + 1);
    currents[start..end.max(start)].to_vec()
}

/// The MISSION_ITEM_REACHED seqs before the landing item's (see the module's doc).
fn before_landing(r: &Value) -> Vec<u64> {
    let reached = r["jump"]["reached"].as_array().expect("reached").iter().filter_map(Value::as_u64);
    reached.take_while(|&s| s != 6).collect()
}

/// What either stack must report.
fn assert_sane(stack: &str, r: &Value) {
    let acks = &r["acks"];
    for (probe, want) in [
        ("condition_gate", "MAV_MISSION_UNSUPPORTED"),
        ("jump_to_home", "MAV_MISSION_ERROR"),
        ("jump_past_end", "MAV_MISSION_ERROR"),
        ("gimbal_nan_rates", "MAV_MISSION_INVALID_PARAM3"),
    ] {
        assert_eq!(acks[probe], want, "{stack}: {probe}: {acks:#}");
    }
    let accepted = acks.as_object().expect("acks").values().filter(|v| *v == "MAV_MISSION_ACCEPTED").count();
    assert_eq!(accepted, 18, "{stack}: every other probe ACCEPTED: {acks:#}");
    assert_eq!(r["survey"]["ack"], "MAV_MISSION_ACCEPTED", "{stack}: survey {}", r["survey"]);
    assert_eq!(r["survey"]["downloaded_identical"], true, "{stack}: survey {}", r["survey"]);
    assert_eq!(r["jump"]["ack"], "MAV_MISSION_ACCEPTED", "{stack}: {}", r["jump"]);
    assert_eq!(before_landing(r), [1, 2, 3, 2, 3, 5], "{stack}: {}", r["jump"]);
    assert_eq!(flown(r), [2, 3, 2, 3, 5, 6], "{stack}: {}", r["jump"]);
}

#[test]
fn survey_and_jump_missions_are_answered_and_flown_as_arducopter_does() {
    let started = Instant::now();
    let dir = temp_dir("mission-items");
    let kestrel =
        scripted_session(&dir, "mission-items", SCRIPT, &[], |port| sim_config(&session_link(port, &dir)));
    let ours = results(&kestrel);
    assert_sane("kestrel", ours);
    println!("kestrel half: {:.1} s", started.elapsed().as_secs_f64());

    let Some(binary) = arducopter::binary() else { return };
    let sitl_started = Instant::now();
    let ardu = arducopter::scripted_session(&binary, SCRIPT, &[]);
    println!("ArduCopter half: {:.1} s", sitl_started.elapsed().as_secs_f64());
    let theirs = results(&ardu);
    assert_sane("arducopter", theirs);
    assert_eq!(ours["acks"], theirs["acks"], "the same MISSION_ACK for every probe");
    assert_eq!(before_landing(ours), before_landing(theirs));
    assert_eq!(theirs["jump"]["reached"].as_array().and_then(|r| r.last()), Some(&Value::from(5)));
    assert_eq!(ours["jump"]["reached"].as_array().and_then(|r| r.last()), Some(&Value::from(6)));
    assert_eq!(flown(ours), flown(theirs));
    let _ = std::fs::remove_dir_all(&dir);
    println!("whole test: {:.1} s", started.elapsed().as_secs_f64());
}
