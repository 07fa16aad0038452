//! The `log_replay` actor in whole graphs: a recorded flight's sensors, replayed through the
//! estimator, give the flight's own estimate back; a bad log, topic or type is a config error
//! naming it; the run ends with the log unless told to stop publishing instead.

use std::path::{Path, PathBuf};
use std::time::Duration;

use kestrel::flight_log::FlightLog;
use kestrel::recorder::LogReader;
use kestrel::replay::replay;
use kestrel::{LoadedConfig, Registry, RunError, RunOptions, RunReport, run};
use kestrel_estimator::EkfParams;
use kestrel_proto::Time;
use kestrel_proto::messages::NavState;

/// 10 s of the simulator flying `leg-40m.plan` (see config/bench-estimator-replay.toml).
fn flight_log() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/sim-flight-10s.mcap")
}

/// A fresh path for `name` under cargo's per-test scratch directory.
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("log_replay");
    std::fs::create_dir_all(&dir).expect("create scratch dir");
    let path = dir.join(name);
    let _ = std::fs::remove_file(&path);
    path
}

/// Runs a graph of a replay (with `replay` as its params) and an estimator, plus `extra` TOML
/// tables, written to a scratch config `name`.
fn run_replay(name: &str, replay: &str, extra: &str, duration_s: f64) -> Result<RunReport, RunError> {
    let text = format!(
        r#"
[run]
clock = "lockstep"

[actors.replay]
type = "log_replay"
params = {replay}

[actors.estimator]
type = "estimator"
params = {{ mag_declination_deg = -2.0 }}
inputs.imu = {{ topic = "imu", mailbox = "queue(64)" }}
inputs.gps = {{ topic = "gps", mailbox = "queue(8)" }}
inputs.baro = {{ topic = "baro", mailbox = "queue(8)" }}
inputs.mag = {{ topic = "mag", mailbox = "queue(16)" }}

{extra}
"#
    );
    let path = scratch(name);
    std::fs::write(&path, &text).expect("write config");
    let config = LoadedConfig::load(&path).expect("config parses");
    let options = RunOptions {
        duration: Some(Duration::from_secs_f64(duration_s)),
        speedup: Some(0.0),
        ..RunOptions::default()
    };
    run(&config, &Registry::standard(), options)
}

fn sensors(log: &Path) -> String {
    format!(r#"{{ log = "{}", topics = ["imu", "gps", "baro", "mag"] }}"#, log.display())
}

fn config_error(outcome: Result<RunReport, RunError>) -> String {
    match outcome {
        Err(RunError::Config(errors)) => {
            errors.iter().map(ToString::to_string).collect::<Vec<_>>().join("\n")
        }
        Err(other) => panic!("expected a config error, got {other}"),
        Ok(_) => panic!("expected a config error, the graph ran"),
    }
}

/// Angle between two attitude quaternions (degrees), whatever their sign.
fn angle_deg(a: [f64; 4], b: [f64; 4]) -> f64 {
    let dot: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
    (2.0 * dot.abs().min(1.0).acos()).to_degrees()
}

/// config/bench-estimator-replay.toml (replay → estimator → link) recomputes the flight's
/// nav_state from its recorded sensors: matched by estimate time, the RMS position and attitude
/// differences are printed and must be within 5 cm and 0.5°. (The lockstep graph is
/// deterministic and the estimator sees the same samples at the same graph times, so on this
/// machine both are 0: the replay reproduces the flight's estimate exactly.)
#[test]
fn replaying_the_sensors_through_the_estimator_gives_the_recorded_estimate_back() {
    let config_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/bench-estimator-replay.toml");
    let config = LoadedConfig::load(&config_path).expect("config parses");
    let out = scratch("replayed.mcap");
    let options = RunOptions { speedup: Some(0.0), record: Some(out.clone()), ..RunOptions::default() };
    let report = run(&config, &Registry::standard(), options).expect("replay runs");
    // The run ended with the log (10 s), not by a duration.
    assert!(report.end_time >= Time::from_micros(9_990_000), "ended at {}", report.end_time);
    assert!(report.end_time <= Time::from_micros(10_010_000), "ended at {}", report.end_time);
    for mailbox in &report.mailboxes {
        assert_eq!(mailbox.overflowed, 0, "{} overflowed", mailbox.route);
    }

    let recorded = LogReader::open(&flight_log()).unwrap().read::<NavState>("nav_state").unwrap();
    let replayed = LogReader::open(&out).unwrap().read::<NavState>("nav_state").unwrap();
    let by_time: std::collections::HashMap<Time, &NavState> =
        replayed.iter().map(|r| (r.message.time, &r.message)).collect();
    let (mut n, mut sq_pos, mut sq_att) = (0usize, 0.0, 0.0);
    for r in &recorded {
        let Some(ours) = by_time.get(&r.message.time) else { continue };
        let (p, q) = (ours.position_ned_m, r.message.position_ned_m);
        sq_pos += (0..3).map(|i| (p[i] - q[i]).powi(2)).sum::<f64>();
        sq_att += angle_deg(ours.attitude, r.message.attitude).powi(2);
        n += 1;
    }
    assert!(n * 10 >= recorded.len() * 9, "only {n} of {} recorded estimates matched", recorded.len());
    let rms_position_m = (sq_pos / n as f64).sqrt();
    let rms_attitude_deg = (sq_att / n as f64).sqrt();
    println!(
        "{n} of {} estimates matched; RMS position difference {rms_position_m:.6} m, attitude {rms_attitude_deg:.6} deg",
        recorded.len()
    );
    assert!(rms_position_m < 0.05, "RMS position difference {rms_position_m} m");
    assert!(rms_attitude_deg < 0.5, "RMS attitude difference {rms_attitude_deg} deg");
}

#[test]
fn the_run_ends_with_the_log() {
    let report = run_replay("end.toml", &sensors(&flight_log()), "", 10.5).expect("runs");
    assert!(report.end_time < Time::from_micros(10_010_000), "ended at {}", report.end_time);
}

#[test]
fn speed_two_replays_ten_seconds_of_log_in_five() {
    let fast = format!(
        r#"{{ log = "{}", topics = ["imu", "gps", "baro", "mag"], speed = 2.0 }}"#,
        flight_log().display()
    );
    let report = run_replay("fast.toml", &fast, "", 20.0).expect("runs");
    let end = report.end_time.as_secs_f64();
    assert!((4.9..5.1).contains(&end), "ended at {end} s");
}

#[test]
fn a_missing_log_is_a_config_error_naming_the_file() {
    let missing = scratch("no-such-flight.mcap");
    let message = config_error(run_replay("missing.toml", &sensors(&missing), "", 1.0));
    assert!(message.contains("no-such-flight.mcap") && message.contains("replay"), "{message}");
}

#[test]
fn a_topic_the_log_lacks_is_named_with_the_topics_it_has() {
    let params = format!(r#"{{ log = "{}", topics = ["imu", "imu2"] }}"#, flight_log().display());
    let message = config_error(run_replay("unknown.toml", &params, "", 1.0));
    assert!(message.contains("`imu2`") && message.contains("sim-flight-10s.mcap"), "{message}");
    assert!(message.contains("baro, battery, gps, imu, mag, nav_state"), "{message}");
}

#[test]
fn a_topic_of_a_type_that_cannot_be_replayed_is_named_with_its_type() {
    let params = format!(r#"{{ log = "{}", topics = ["imu", "nav_state"] }}"#, flight_log().display());
    let message = config_error(run_replay("navstate.toml", &params, "", 1.0));
    assert!(message.contains("`nav_state` holds `kestrel.NavState`"), "{message}");
    assert!(message.contains("kestrel.ImuSample"), "{message}");
}

#[test]
fn an_output_routed_to_a_topic_of_another_type_is_a_type_mismatch() {
    let message = config_error(run_replay(
        "mismatch.toml",
        &sensors(&flight_log()),
        "[actors.replay.outputs]\nbaro = \"mag\"",
        1.0,
    ));
    assert!(message.contains("type mismatch on topic 'mag'"), "{message}");
}

#[test]
fn a_speed_outside_the_pace_range_is_refused() {
    for speed in ["0.0", "1e-300", "inf"] {
        let params =
            format!(r#"{{ log = "{}", topics = ["imu"], speed = {speed} }}"#, flight_log().display());
        let message = config_error(run_replay("speed.toml", &params, "", 1.0));
        assert!(message.contains("`speed` must be within 0.001..=1000000"), "{speed}: {message}");
    }
}

/// One way in for a PX4 ULog too: the actor publishes the ULog's sensor topics (stamped with the
/// log's EKF2 lags) into an estimator, and `kestrel::replay` over the recording of that run
/// (its sensors, through a fresh filter with the same settings) gives the graph's estimate back.
#[test]
fn a_px4_ulog_replays_through_the_graph_as_kestrel_replay_reads_it() {
    let ulog = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/px4/px4_sitl_takeoff_land.ulg");
    let settings = FlightLog::open(&ulog).expect("the ULog reads").settings();
    let params = settings.apply(EkfParams::default());
    let text = format!(
        r#"
[run]
clock = "lockstep"

[record]
topics = ["*"]

[actors.replay]
type = "log_replay"
params = {{ log = "{}", topics = ["sensor_combined", "vehicle_gps_position", "vehicle_air_data", "vehicle_magnetometer"] }}

[actors.estimator]
type = "estimator"
params = {{ gps_lag_s = {}, baro_lag_s = {}, mag_lag_s = {}, mag_declination_deg = {} }}
inputs.imu = {{ topic = "imu", mailbox = "queue(64)" }}
inputs.gps = {{ topic = "gps", mailbox = "queue(8)" }}
inputs.baro = {{ topic = "baro", mailbox = "queue(8)" }}
inputs.mag = {{ topic = "mag", mailbox = "queue(16)" }}
"#,
        ulog.display(),
        params.gps_lag_s,
        params.baro_lag_s,
        params.mag_lag_s,
        params.mag_declination_deg
    );
    let path = scratch("ulog.toml");
    std::fs::write(&path, &text).expect("write config");
    let config = LoadedConfig::load(&path).expect("config parses");
    let out = scratch("ulog-replayed.mcap");
    let options = RunOptions { speedup: Some(0.0), record: Some(out.clone()), ..RunOptions::default() };
    let report = run(&config, &Registry::standard(), options).expect("replay runs");
    for mailbox in &report.mailboxes {
        assert_eq!(mailbox.overflowed, 0, "{} overflowed", mailbox.route);
    }

    let recorded = FlightLog::open(&out).expect("the recording reads");
    let result = replay(&recorded, params).expect("the recording replays");
    let s = result.summary.vs_estimate.as_ref().expect("the graph's nav_state was recorded");
    println!("graph vs kestrel::replay on the ULog's samples: {s:?}");
    assert!(s.rows > 1000, "{s:?}");
    assert!(s.rms_attitude_deg.is_some_and(|a| a < 0.5), "{s:?}");
    assert!(s.rms_horizontal_m.is_some_and(|h| h < 0.05), "{s:?}");
    assert!(s.rms_height_m.is_some_and(|h| h < 0.05), "{s:?}");
}
