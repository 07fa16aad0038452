//! Who is in control, against the real vehicle: pymavlink ground stations
//! (tests/python/gcs_who_is_in_control.py) talk to `kestrel run` on the simulator over UDP
//! loopback at `--speedup 5`, and the verdict is what they see — LOCAL_POSITION_NED and
//! GLOBAL_POSITION_INT, HEARTBEAT mode and state, COMMAND_ACK and STATUSTEXT.
//!
//! * Two ground stations, systems 255 (`MAV_GCS_SYSID`'s default) and 254, send opposite
//!   MANUAL_CONTROL in POSHOLD: only 255's flies; then 254's heartbeats alone do not hold off the
//!   ground-station failsafe.
//! * One full-deflection MANUAL_CONTROL and 8 s of silence: ACRO and arming are refused; with
//!   live sticks and the throttle low they are accepted.
//!
//! The vehicle's config is config/sim.toml with the link sending to each station's port.

mod support;
use support::sim_vehicle;

use std::time::{Duration, Instant};

use sim_vehicle::{kestrel_at_5x, python_client, sim_config, stop, tail, temp_dir, transcript_until_exit};

/// Wall-clock bound on one client.
const CLIENT_LIMIT: Duration = Duration::from_secs(70);

/// Runs `gcs_who_is_in_control.py SCENARIO` against `kestrel run`, the link sending to each of
/// the `stations` ports the client announces; returns the client's result JSON.
fn session(scenario: &str, stations: usize) -> serde_json::Value {
    let dir = temp_dir(&format!("control-{scenario}"));
    let (mut client, lines) = python_client("gcs_who_is_in_control.py", |c| c.arg(scenario));
    let ports: Vec<u16> = (0..stations)
        .map(|_| {
            let line = lines.recv_timeout(Duration::from_secs(15)).unwrap_or_default();
            line.strip_prefix("PORT ").and_then(|p| p.trim().parse().ok()).expect("a station's port")
        })
        .collect();
    let endpoints: Vec<String> =
        ports.iter().map(|p| format!("{{ type = \"udp_out\", address = \"127.0.0.1:{p}\" }}")).collect();
    let link = format!("params.system_id = 1\nparams.endpoints = [ {} ]\n", endpoints.join(", "));
    let config_path = dir.join("graph.toml");
    std::fs::write(&config_path, sim_config(&link)).expect("config");
    let log_path = dir.join("kestrel.log");
    let mut kestrel = kestrel_at_5x(&dir, &config_path, &log_path, "400");
    println!("── {scenario}: stations on ports {ports:?} ──");
    let started = Instant::now();
    let (exit, transcript) = transcript_until_exit(&mut client, &lines, || started.elapsed() > CLIENT_LIMIT);
    let log = || tail(&std::fs::read_to_string(&log_path).unwrap_or_default(), 30);
    assert!(exit.is_some_and(|s| s.success()), "{scenario}: client {exit:?}\n{transcript:#?}\n{}", log());
    assert!(stop(&mut kestrel, scenario).success(), "{scenario}: kestrel failed\n{}", log());
    println!("── {scenario}: took {:.1} s ──", started.elapsed().as_secs_f64());
    let last = transcript.last().expect("a result line");
    let result: serde_json::Value = serde_json::from_str(last).expect("JSON result line");
    std::fs::remove_dir_all(&dir).ok();
    result["results"].clone()
}

#[test]
fn only_mav_gcs_sysid_flies_and_another_stations_heartbeats_do_not_hold_off_the_gcs_failsafe() {
    let r = session("two_stations", 2);
    let forward = &r["opposite_sticks"];
    assert_eq!(forward["ignored_text"], "Sticks from sysid 254 ignored (MAV_GCS_SYSID 255)", "{r:#}");
    let (local, global) = (forward["forward_local_m"].as_f64(), forward["forward_global_m"].as_f64());
    assert!(local.is_some_and(|m| m > 10.0) && global.is_some_and(|m| m > 10.0), "{r:#}");
    let failsafe = &r["gcs_failsafe"];
    assert_eq!(failsafe["mode"], "RTL", "{r:#}");
    assert_eq!(failsafe["system_status"], "MAV_STATE_CRITICAL", "{r:#}");
    // FS_GCS_TIMEOUT_S is 5 s; the stations are seen at 2 Hz of vehicle time.
    let after = failsafe["after_s"].as_f64().expect("after_s");
    assert!((4.5..7.0).contains(&after), "failsafe {after} s after 255 fell silent: {r:#}");
}

#[test]
fn one_stale_deflection_arms_nothing_and_live_low_sticks_arm_acro() {
    let r = session("stale_sticks", 1);
    assert_ne!(r["stale"]["acro"], "MAV_RESULT_ACCEPTED", "{r:#}");
    assert_ne!(r["stale"]["arm"], "MAV_RESULT_ACCEPTED", "{r:#}");
    let why = r["stale"]["why"].as_str().expect("why");
    let age_s = why.strip_prefix("Arm: Stabilize: no manual control for ").and_then(|s| s.strip_suffix(" s"));
    assert!(age_s.and_then(|s| s.parse::<f64>().ok()).is_some_and(|s| (7.9..10.0).contains(&s)), "{why}");
    assert_eq!(r["live"]["arm"], "MAV_RESULT_ACCEPTED", "{r:#}");
    assert_eq!(r["live"]["armed"], true, "{r:#}");
}
