//! MAV_CMD_DO_MOTOR_TEST and MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN as a ground station asks for them,
//! by one pymavlink script, tests/python/gcs_reboot_motor_test.py, against `kestrel run` (a child
//! process on config/sim.toml) and ArduCopter SITL (when `KESTREL_ARDUCOPTER` names it); the
//! test compares the ACKs and what SERVO_OUTPUT_RAW showed.
//!
//! Both stacks: a disarmed motor test is ACCEPTED; motor 1 of the test order at 30 % shows
//! 1300 µs on its servo for its 2 s and then rest; four motors in sequence at 1300 µs rise in
//! the test order, clockwise from the front, 1 s each: servos 1, 4, 2, 3 on Kestrel's quad-X,
//! 3, 1, 4, 2 on the SITL's "+" frame (front, right, back, left: ArduCopter's own transcript,
//! up 1.95 s and 0.95 s in its 20 Hz SERVO_OUTPUT_RAW). Kestrel also stops a test on any other command
//! and on a lost ground station (5 s without a heartbeat), where ArduCopter waits out the
//! test's time (it turns its GCS failsafe off for a test): asserted on Kestrel alone. Armed, a
//! reboot and a motor test are refused (Kestrel DENIED, ArduCopter FAILED) and the vehicle stays
//! armed. Disarmed, the reboot is ACCEPTED: `kestrel run` then exits with
//! `kestrel::reboot::REBOOT_EXIT_CODE` (75), which packaging/kestrel.service restarts on;
//! ArduCopter SITL restarts in its own process.

mod support;
use support::{arducopter, sim_vehicle};

use std::time::{Duration, Instant};

use serde_json::Value;
use sim_vehicle::{
    kestrel_at_5x, python_client, session_link, sim_config, stop, tail, temp_dir, transcript_until_exit,
};

const SCRIPT: &str = "gcs_reboot_motor_test.py";

fn ack<'a>(r: &'a Value, step: &str) -> &'a str {
    r["acks"][step].as_str().unwrap_or_else(|| panic!("no ACK for {step}: {r:#}"))
}

fn runs(r: &Value, step: &str) -> Vec<(u64, u64, f64)> {
    r[step]["runs"]
        .as_array()
        .unwrap_or_else(|| panic!("no {step} runs: {r:#}"))
        .iter()
        .map(|x| {
            (
                x["servo"].as_u64().expect("servo"),
                x["pulse_us"].as_u64().expect("pulse"),
                x["up_s"].as_f64().expect("up_s"),
            )
        })
        .collect()
}

/// What both stacks must show (1000..2000 µs outputs), `order` the frame's servos in test order.
fn assert_common(stack: &str, r: &Value, order: [u64; 4]) {
    for step in ["single", "sequence"] {
        assert_eq!(ack(r, step), "MAV_RESULT_ACCEPTED", "{stack}: {step}: {r:#}");
        assert_eq!(r[step]["rest_after"], true, "{stack}: {step} ended at rest: {r:#}");
    }
    let single = runs(r, "single");
    assert_eq!(single.len(), 1, "{stack}: one motor spun: {single:?}");
    let (servo, pulse, up) = single[0];
    assert_eq!(servo, order[0], "{stack}: motor 1 of the test order");
    assert!(pulse.abs_diff(1300) <= 2, "{stack}: 30 % of 1000..2000 µs, shown {pulse}");
    assert!((up - 2.0).abs() < 0.2, "{stack}: spun {up} s of 2");
    let sequence = runs(r, "sequence");
    let servos: Vec<u64> = sequence.iter().map(|s| s.0).collect();
    assert_eq!(servos, order, "{stack}: the test order A-D: {sequence:?}");
    for (servo, pulse, up) in sequence {
        assert!(pulse.abs_diff(1300) <= 2, "{stack}: servo {servo} at {pulse} µs");
        assert!((up - 1.0).abs() < 0.2, "{stack}: servo {servo} spun {up} s of 1");
    }
    if r["acks"].get("reboot_armed").is_some() {
        for step in ["reboot_armed", "motor_test_armed"] {
            let a = ack(r, step);
            assert!(
                a == "MAV_RESULT_FAILED" || a == "MAV_RESULT_DENIED",
                "{stack}: {step} answered {a}: {r:#}"
            );
        }
        assert_eq!(r["armed_after_refusals"], true, "{stack}: the refusals changed nothing");
    }
    assert_eq!(ack(r, "reboot"), "MAV_RESULT_ACCEPTED", "{stack}: disarmed reboot");
}

#[test]
fn motor_tests_spin_what_arducopter_spins_and_a_reboot_restarts_the_process() {
    let started = Instant::now();
    let dir = temp_dir("reboot-motor-test");
    let (mut client, lines) = python_client(SCRIPT, |c| c);
    let first = lines.recv_timeout(Duration::from_secs(15)).unwrap_or_default();
    let port: u16 = first.strip_prefix("PORT ").and_then(|p| p.trim().parse().ok()).expect("client port");
    let config_path = dir.join("reboot.toml");
    std::fs::write(&config_path, sim_config(&session_link(port, &dir))).expect("config");
    let log_path = dir.join("reboot.log");
    let mut kestrel = kestrel_at_5x(&dir, &config_path, &log_path, "600");
    let (exit, transcript) =
        transcript_until_exit(&mut client, &lines, || started.elapsed() > Duration::from_secs(150));
    let log = || tail(&std::fs::read_to_string(&log_path).unwrap_or_default(), 30);
    assert!(exit.is_some_and(|s| s.success()), "client {exit:?}\n{}", log());
    // The process ends by itself after the accepted reboot; SIGTERM only if it did not.
    let waiting = Instant::now();
    while kestrel.0.try_wait().expect("kestrel status").is_none()
        && waiting.elapsed() < Duration::from_secs(10)
    {
        std::thread::sleep(Duration::from_millis(20));
    }
    let status = stop(&mut kestrel, "reboot");
    assert_eq!(
        status.code(),
        Some(i32::from(kestrel::reboot::REBOOT_EXIT_CODE)),
        "kestrel run exits with the reboot code: {status:?}\n{}",
        log()
    );
    let last = transcript.last().expect("a result line");
    let ours: Value = serde_json::from_str(last).expect("JSON result");
    let ours = &ours["results"];
    assert_common("kestrel", ours, [1, 4, 2, 3]);
    let stopped = ours["stopped"]["rest_after_s"].as_f64();
    assert!(stopped.is_some_and(|s| s < 0.5), "another command stops the test at once: {ours:#}");
    let lost = ours["gcs_lost"]["rest_after_s"].as_f64();
    assert!(
        lost.is_some_and(|s| (4.5..7.0).contains(&s)),
        "5 s without a heartbeat stops the test: {ours:#}"
    );
    let silence = ours["reboot_silence_s"].as_f64().expect("silence");
    assert!(silence > 2.5, "no heartbeat after the reboot: the process is gone ({silence} s)");
    println!("kestrel half: {:.1} s: {ours}", started.elapsed().as_secs_f64());

    let Some(binary) = arducopter::binary() else { return };
    let sitl_started = Instant::now();
    // Arming needs ArduCopter's EKF on GPS (some 40 s of its time); the armed refusals are
    // held for it by tests/gcs_modes.rs in the air.
    let ardu = arducopter::scripted_session(&binary, SCRIPT, &[("SKIP_ARMED", "1".into())]);
    println!("ArduCopter half: {:.1} s", sitl_started.elapsed().as_secs_f64());
    let theirs = &ardu["results"];
    assert_common("arducopter", theirs, [3, 1, 4, 2]);
    println!("ArduCopter: {theirs}");
    for step in ["single", "sequence", "reboot"] {
        assert_eq!(ack(ours, step), ack(theirs, step), "{step}");
    }
    assert_eq!(ours["idle"], theirs["idle"], "outputs at rest");
    let _ = std::fs::remove_dir_all(&dir);
    println!("whole test: {:.1} s", started.elapsed().as_secs_f64());
}
