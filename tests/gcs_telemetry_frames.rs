//! The telemetry frames SDKs and ground stations read beyond the basics (ATTITUDE_QUATERNION,
//! the IMU and barometer, SYSTEM_TIME, TIMESYNC, SERVO_OUTPUT_RAW, ODOMETRY), asked for and
//! observed by one pymavlink script, tests/python/gcs_telemetry_frames.py, against `kestrel run`
//! and ArduCopter SITL (when `KESTREL_ARDUCOPTER` names it, see tests/support/arducopter.rs); the
//! test compares what each reported.
//!
//! What ArduCopter 4.7 does (SITL on `copter.parm`, the script's transcript): nothing is streamed
//! until asked; after REQUEST_DATA_STREAM ALL at 4 Hz, RAW_IMU and SCALED_PRESSURE
//! (RAW_SENSORS), SERVO_OUTPUT_RAW and RC_CHANNELS (RC_CHANNELS), SYSTEM_TIME (EXTRA3) and
//! NAV_CONTROLLER_OUTPUT (EXTENDED_STATUS) come at 4 Hz (NAV_CONTROLLER_OUTPUT compared too); ATTITUDE_QUATERNION, SCALED_IMU and
//! HIGHRES_IMU only on request (REQUEST_MESSAGE ACCEPTED and sent; SET_MESSAGE_INTERVAL
//! honoured); ODOMETRY is refused (FAILED, nothing sent); a TIMESYNC request is answered with
//! its `tc1` set and the request's `ts1` mirrored; armed on the ground in GUIDED its motor outputs
//! read 1000 µs.
//!
//! Kestrel does the same for the frames it sends, with one difference on purpose: ODOMETRY is
//! sent on request (MAVSDK's `telemetry.odometry` asks for it, as PX4 sends it). Kestrel streams
//! its 4 Hz frames unasked too, as it streams every other frame; RC_CHANNELS and
//! POSITION_TARGET_* are reported, not compared ([`NOT_COMPARED`]).

mod support;
use support::{arducopter, sim_vehicle};

use std::time::Instant;

use serde_json::Value;
use sim_vehicle::{scripted_session, session_link, sim_config, temp_dir};

const SCRIPT: &str = "gcs_telemetry_frames.py";

/// Streamed at the 4 Hz asked for, by both.
const STREAMED: [&str; 5] =
    ["RAW_IMU", "SCALED_PRESSURE", "SYSTEM_TIME", "SERVO_OUTPUT_RAW", "NAV_CONTROLLER_OUTPUT"];
/// Sent only when asked for, by both (ODOMETRY: by Kestrel).
const ON_REQUEST: [&str; 4] = ["ATTITUDE_QUATERNION", "SCALED_IMU", "HIGHRES_IMU", "ODOMETRY"];
/// Frames reported, not compared: RC_CHANNELS (Kestrel sends it only while sticks come, and the
/// simulated graph has no receiver; ArduCopter SITL simulates one) and POSITION_TARGET_* (from
/// the commander's setpoint, only while armed, which this script's listening window is not;
/// neither stack sends them then, and ArduCopter ACKs a request ACCEPTED that sends nothing
/// where Kestrel answers DENIED).
const NOT_COMPARED: [&str; 3] = ["RC_CHANNELS", "POSITION_TARGET_LOCAL_NED", "POSITION_TARGET_GLOBAL_INT"];
/// The stream rate asked for (Hz) and how far a measured rate may be from it: the vehicle's
/// 20 ms scheduler tick and the 6 s window of vehicle time.
const STREAM_HZ: f64 = 4.0;
const RATE_TOLERANCE: f64 = 0.2;

fn results(v: &Value) -> &Value {
    let r = &v["results"];
    assert!(r.is_object(), "no results in {v:#}");
    r
}

fn hz(r: &Value, name: &str) -> f64 {
    r["streamed_hz"][name].as_f64().unwrap_or_else(|| panic!("no rate of {name}: {r:#}"))
}

fn near(rate: f64, target: f64) -> bool {
    (rate - target).abs() <= RATE_TOLERANCE * target
}

/// What either stack must report for the frames both send.
fn assert_sane(stack: &str, r: &Value) {
    for name in STREAMED {
        assert!(
            near(hz(r, name), STREAM_HZ),
            "{stack}: {name} at {} Hz, asked {STREAM_HZ}: {r:#}",
            hz(r, name)
        );
    }
    for name in ON_REQUEST.iter().filter(|n| **n != "ODOMETRY") {
        assert_eq!(hz(r, name), 0.0, "{stack}: {name} streamed unasked: {r:#}");
    }
    for name in STREAMED.iter().chain(ON_REQUEST.iter().filter(|n| **n != "ODOMETRY")) {
        let asked = &r["requested"][name];
        assert_eq!(asked["ack"], "MAV_RESULT_ACCEPTED", "{stack}: REQUEST_MESSAGE {name}: {asked}");
        assert_eq!(asked["came"], true, "{stack}: REQUEST_MESSAGE {name} ACCEPTED but never sent");
    }
    let interval = &r["interval"];
    assert_eq!(interval["ack"], "MAV_RESULT_ACCEPTED", "{stack}: {interval}");
    let aq_hz = interval["hz"].as_f64().expect("a rate");
    assert!(near(aq_hz, 20.0), "{stack}: ATTITUDE_QUATERNION at {aq_hz} Hz, asked 20: {interval}");
    assert_eq!(
        r["timesync"],
        serde_json::json!({"answered": true, "tc1_set": true, "ts1_mirrored": true}),
        "{stack}: TIMESYNC"
    );
    let checks = r["checks"].as_object().expect("checks");
    for (check, ok) in checks {
        assert_eq!(ok, &Value::Bool(true), "{stack}: {check} ({ok}): {r:#}");
    }
    let servo = r["armed_servo"].as_array().unwrap_or_else(|| panic!("{stack}: no SERVO_OUTPUT_RAW armed"));
    assert!(
        servo.iter().all(|p| p.as_u64().is_some_and(|p| (1000..=2000).contains(&p))),
        "{stack}: armed motor outputs outside 1000..2000 µs: {servo:?}"
    );
}

#[test]
fn telemetry_frames_come_as_arducopter_sends_them() {
    let started = Instant::now();
    let dir = temp_dir("telemetry-frames");
    let kestrel =
        scripted_session(&dir, "telemetry-frames", SCRIPT, &[], |port| sim_config(&session_link(port, &dir)));
    let ours = results(&kestrel);
    assert_sane("kestrel", ours);
    let odometry = &ours["requested"]["ODOMETRY"];
    assert_eq!(
        (&odometry["ack"], &odometry["came"]),
        (&Value::from("MAV_RESULT_ACCEPTED"), &Value::Bool(true)),
        "ODOMETRY on request, as PX4 sends it"
    );
    println!("kestrel half: {:.1} s", started.elapsed().as_secs_f64());

    let Some(binary) = arducopter::binary() else { return };
    let sitl_started = Instant::now();
    let ardu = arducopter::scripted_session(&binary, SCRIPT, &[]);
    println!("ArduCopter half: {:.1} s", sitl_started.elapsed().as_secs_f64());
    let theirs = results(&ardu);
    assert_sane("arducopter", theirs);
    for name in STREAMED {
        let (a, b) = (hz(ours, name), hz(theirs, name));
        assert!((a - b).abs() <= RATE_TOLERANCE * b, "{name}: kestrel {a} Hz, ArduCopter {b} Hz");
    }
    for name in STREAMED.iter().chain(&ON_REQUEST).filter(|n| **n != "ODOMETRY") {
        assert_eq!(ours["requested"][name], theirs["requested"][name], "REQUEST_MESSAGE {name}");
    }
    // The difference on purpose: ArduCopter refuses ODOMETRY.
    println!("ODOMETRY requested: ArduCopter {}, Kestrel {}", theirs["requested"]["ODOMETRY"], odometry);
    for name in NOT_COMPARED {
        println!(
            "not compared, {name}: ArduCopter streams {} Hz and answers {}; Kestrel streams {} Hz and answers {}",
            theirs["streamed_hz"][name],
            theirs["requested"][name],
            ours["streamed_hz"][name],
            ours["requested"][name]
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
    println!("whole test: {:.1} s", started.elapsed().as_secs_f64());
}
