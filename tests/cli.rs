//! The `kestrel` binary as a person runs it.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use kestrel::recorder::{LogReader, Recorded};
use kestrel_proto::Message;
use kestrel_proto::messages::{BaroSample, BatteryStatus, GpsFix, GroundTruth, ImuSample, MagSample};

/// The binary, from the repository's root. Several of these tests run the default graph at
/// once, which the instance lock would refuse (`kestrel::locks`): each test keeps its locks in a
/// folder of its own.
fn kestrel() -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_kestrel"));
    cmd.current_dir(env!("CARGO_MANIFEST_DIR"))
        .env_remove("RUST_LOG")
        .env("KESTREL_LOCK_DIR", temp_path("locks"));
    cmd
}

/// Runs `cmd` and fails the test, showing its stderr, unless it exits 0.
fn succeed(cmd: &mut Command) -> std::process::Output {
    let out = cmd.output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    out
}

fn temp_path(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("kestrel-cli-{}-{name}", std::process::id()))
}

fn read<T: Message>(log: &LogReader, topic: &str) -> Vec<Recorded<T>> {
    log.read::<T>(topic).unwrap_or_else(|e| panic!("{topic}: {e}"))
}

/// Mean rate over the stream's span (Hz), from measurement times.
fn rate_hz<T: Message>(msgs: &[Recorded<T>]) -> f64 {
    let span = msgs.last().unwrap().publish_time.as_secs_f64() - msgs[0].publish_time.as_secs_f64();
    (msgs.len() - 1) as f64 / span
}

/// Every message's lag: when it was published minus when it was measured (s).
fn lags_s<T: Message>(msgs: &[Recorded<T>]) -> Vec<f64> {
    msgs.iter().map(|m| m.log_time.as_secs_f64() - m.publish_time.as_secs_f64()).collect()
}

#[test]
fn ten_second_run_records_every_sensor_at_its_rate() {
    let path = temp_path("run10.mcap");
    succeed(kestrel().args(["run", "--duration", "10", "--speedup", "0", "--quiet", "--record"]).arg(&path));
    let log = LogReader::open(&path).unwrap();
    let imu = read::<ImuSample>(&log, "imu");
    let gps = read::<GpsFix>(&log, "gps");
    let baro = read::<BaroSample>(&log, "baro");
    let mag = read::<MagSample>(&log, "mag");
    let truth = read::<GroundTruth>(&log, "ground_truth");
    let battery = read::<BatteryStatus>(&log, "battery");
    let _ = std::fs::remove_file(&path);

    let within = |got: f64, want: f64| (got - want).abs() <= 0.01 * want;
    assert_eq!(imu.len(), 4000, "IMU at 400 Hz for 10 s");
    assert!(within(rate_hz(&imu), 400.0), "imu {}", rate_hz(&imu));
    assert!(within(rate_hz(&gps), 5.0) && gps.len() >= 48, "gps {} Hz, {}", rate_hz(&gps), gps.len());
    assert!(within(rate_hz(&baro), 10.0) && baro.len() >= 99, "baro {} Hz, {}", rate_hz(&baro), baro.len());
    assert!(within(rate_hz(&mag), 100.0), "mag {}", rate_hz(&mag));
    assert!(truth.len() >= 499 && battery.len() >= 99, "truth {} battery {}", truth.len(), battery.len());
    assert!(lags_s(&gps).iter().all(|l| (l - 0.220).abs() < 1e-6), "gps lag {:?}", &lags_s(&gps)[..3]);
    assert!(lags_s(&baro).iter().all(|l| (l - 0.050).abs() < 1e-6), "baro lag {:?}", &lags_s(&baro)[..3]);
    assert!(lags_s(&imu).iter().all(|l| l.abs() < 1e-6), "the IMU is not lagged");
    let at_rest = truth.last().unwrap();
    assert!(at_rest.message.landed && !at_rest.message.crashed, "{:?}", at_rest.message);
}

#[cfg(unix)]
#[test]
fn sigterm_stops_within_a_second_and_leaves_a_readable_log() {
    let path = temp_path("sigterm.mcap");
    let mut child = kestrel()
        .args(["run", "--speedup", "1", "--quiet", "--record"])
        .arg(&path)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    let signalled = Instant::now();
    let kill = Command::new("kill").args(["-TERM", &child.id().to_string()]).status().unwrap();
    assert!(kill.success());
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        assert!(signalled.elapsed() < Duration::from_secs(5), "kestrel ignored SIGTERM");
        std::thread::sleep(Duration::from_millis(5));
    };
    let took = signalled.elapsed();
    assert!(status.success(), "exit status {status:?}");
    assert!(took < Duration::from_secs(1), "shutdown took {took:?}");
    let mut stderr = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut stderr).unwrap();
    let log = LogReader::open(&path).unwrap();
    let imu = read::<ImuSample>(&log, "imu");
    let in_file: u64 = log.topics().iter().map(|t| t.message_count).sum();
    let _ = std::fs::remove_file(&path);
    // Everything the recorder took before the signal is in the file: how much that is depends
    // on how fast a loaded machine simulated, so the run's own count is the reference.
    let recorded: u64 = stderr
        .lines()
        .find_map(|l| l.split_once("recorded ")?.1.split_once(" messages")?.0.parse().ok())
        .unwrap_or_else(|| panic!("no `recorded N messages` line in:\n{stderr}"));
    assert_eq!(in_file, recorded, "messages in the file against those recorded");
    assert!(
        !imu.is_empty() && log.damage().is_none(),
        "{} IMU samples, damage {:?}",
        imu.len(),
        log.damage()
    );
}

#[test]
fn a_config_with_an_unknown_actor_fails_naming_it() {
    let path = temp_path("bad.toml");
    std::fs::write(&path, "[actors.sim]\ntype = \"sim\"\n\n[actors.eye]\ntype = \"laser_eyes\"\n").unwrap();
    let out = kestrel().args(["run", "--duration", "1", "--config"]).arg(&path).output().unwrap();
    let _ = std::fs::remove_file(&path);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains(&format!("{}:5: unknown actor type 'laser_eyes'", path.display())), "{stderr}");
}

/// A Zenoh bridge in a config: refused with its parameter named in a build with the bridge, and
/// with the feature that brings it in a build without.
#[test]
fn a_bridge_is_refused_naming_its_bad_parameter_or_the_missing_feature() {
    let path = temp_path("bridge.toml");
    std::fs::write(
        &path,
        "[actors.sim]\ntype = \"sim\"\n\n[actors.bridge]\ntype = \"bridge\"\nparams = { vehicle = \"v\", listen = [\"tcp/127.0.0.1:0\"], publish = [\"imu\"] }\n",
    )
    .unwrap();
    let out = kestrel().args(["run", "--duration", "1", "--config"]).arg(&path).output().unwrap();
    let _ = std::fs::remove_file(&path);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    let expected = if cfg!(feature = "zenoh") {
        "parameter 'publish': topic 'imu' is not bridged; bridged topics: nav_state, ground_truth"
    } else {
        "actor 'bridge' of type 'bridge': this kestrel was built without the Zenoh bridge (cargo build --features zenoh)"
    };
    assert!(stderr.contains(expected), "{stderr}");
}

#[test]
fn bad_input_files_and_values_are_named_and_refused_without_a_panic() {
    let plan = temp_path("bad.plan");
    std::fs::write(
        &plan,
        r#"{"fileType": "Plan", "mission": {"items": [
            {"type": "SimpleItem", "command": 22, "frame": 3, "params": [0,0,0,null,null,null,10]},
            {"type": "SimpleItem", "command": 19, "frame": 3, "params": [-4,0,0,null,6.8,79.9,10]}]}}"#,
    )
    .unwrap();
    let out = kestrel().args(["run", "--duration", "1", "--mission"]).arg(&plan).output().unwrap();
    let _ = std::fs::remove_file(&plan);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains(&format!("{}: mission item 1: ", plan.display())), "{stderr}");
    assert!(!stderr.contains("sim.toml"), "the plan's error is the plan's: {stderr}");

    let config = temp_path("inf_status.toml");
    std::fs::write(&config, "[run]\nstatus_period_s = inf\n\n[actors.sim]\ntype = \"sim\"\n").unwrap();
    let out = kestrel().args(["run", "--duration", "1", "--config"]).arg(&config).output().unwrap();
    let _ = std::fs::remove_file(&config);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains(&format!("{}:2: [run] status_period_s = inf", config.display())), "{stderr}");

    for duration in ["1e30", "inf"] {
        let out = kestrel().args(["run", "--duration", duration]).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        assert!(stderr.contains("--duration"), "{stderr}");
    }
}

#[test]
fn help_documents_every_flag() {
    let out = kestrel().args(["run", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&out.stdout);
    for flag in ["--config", "--duration", "--speedup", "--record", "--log-level", "--quiet"] {
        assert!(help.contains(flag), "{flag} missing from:\n{help}");
    }
    assert!(Path::new(env!("CARGO_MANIFEST_DIR")).join("config/sim.toml").exists());
}

const THESIS_RULES: &str = "config/avoider/thesis.fll";
const REGIONS: [&str; 9] = ["D_lu", "D_u", "D_ru", "D_l", "D_c", "D_r", "D_ld", "D_d", "D_rd"];

fn fuzzy_inputs(blocked: &[&str], speed: f64) -> Vec<String> {
    let mut args = Vec::new();
    for region in REGIONS {
        args.push("--input".to_owned());
        args.push(format!("{region}={}", if blocked.contains(&region) { 1.0 } else { 0.0 }));
    }
    args.extend(["--input".to_owned(), format!("V_in={speed}")]);
    args
}

#[test]
fn fuzzy_prints_one_line_per_output_and_steers_away() {
    let out =
        succeed(kestrel().args(["fuzzy", "--rules", THESIS_RULES]).args(fuzzy_inputs(&["D_c", "D_l"], 0.2)));
    let stdout = String::from_utf8_lossy(&out.stdout);
    let values: Vec<(String, f64)> = stdout
        .lines()
        .map(|l| {
            let (name, value) = l.split_once('=').unwrap();
            (name.to_owned(), value.parse().unwrap())
        })
        .collect();
    let names: Vec<&str> = values.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["Vx", "Vy", "Vz"], "{stdout}");
    assert!(values[0].1 > 0.2, "obstacle on the left and centre: steer right (table 3.1), got {stdout}");
    assert!(values[1].1 < 0.0, "and slow down, got {stdout}");
}

#[test]
fn fuzzy_json_and_csv_modes() {
    let out = kestrel()
        .args(["fuzzy", "--json", "--rules", THESIS_RULES])
        .args(fuzzy_inputs(&[], 0.5))
        .output()
        .unwrap();
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["outputs"].as_array().unwrap().len(), 3);
    assert_eq!(json["rules"].as_array().unwrap().len(), 18, "the thesis's 18 rules");

    let csv = temp_path("fuzzy.csv");
    let header = REGIONS.iter().chain(["V_in"].iter()).copied().collect::<Vec<_>>().join(",");
    std::fs::write(&csv, format!("{header}\n0,0,0,0,0,0,0,0,0,0.5\n0,0,0,1,1,0,0,0,0,0.2\n")).unwrap();
    let out = kestrel().args(["fuzzy", "--rules", THESIS_RULES, "--csv"]).arg(&csv).output().unwrap();
    let _ = std::fs::remove_file(&csv);
    let stdout = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 3, "{stdout}");
    assert_eq!(lines[0], "Vx,Vy,Vz");

    let out = kestrel().args(["fuzzy", "--rules", THESIS_RULES, "--input", "D_c=1"]).output().unwrap();
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("missing"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn replay_writes_our_estimate_beside_px4s_and_beside_ground_truth() {
    let ulog = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/px4/px4_sitl_takeoff_land.ulg");
    let csv = temp_path("replay-ulog.csv");
    succeed(kestrel().args(["replay", "--log"]).arg(&ulog).arg("--out").arg(&csv));
    let rows = std::fs::read_to_string(&csv).unwrap();
    let _ = std::fs::remove_file(&csv);
    assert!(rows.starts_with(kestrel::replay::CSV_HEADER), "{}", &rows[..80]);
    assert!(rows.lines().count() > 100, "one row per EKF2 attitude sample");

    let mcap = temp_path("replay.mcap");
    succeed(kestrel().args(["run", "--duration", "6", "--speedup", "0", "--quiet", "--record"]).arg(&mcap));
    let out = kestrel().args(["replay", "--log"]).arg(&mcap).arg("--out").arg(&csv).output().unwrap();
    let _ = std::fs::remove_file(&mcap);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let summary = String::from_utf8_lossy(&out.stdout);
    assert!(summary.contains("against ground truth"), "{summary}");
    let rows = std::fs::read_to_string(&csv).unwrap();
    let _ = std::fs::remove_file(&csv);
    assert!(rows.lines().count() > 100, "ground truth at 50 Hz after alignment");
}

#[test]
fn report_scores_the_estimator_against_ground_truth() {
    let json = temp_path("report.json");
    succeed(kestrel().args(["run", "--duration", "8", "--speedup", "0", "--quiet", "--report"]).arg(&json));
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let _ = std::fs::remove_file(&json);
    for field in ["mission", "flight", "estimator", "control", "avoidance", "failsafes"] {
        assert!(report.get(field).is_some(), "{field} missing: {report}");
    }
    assert_eq!(report["flight"]["collisions"], 0);
    let horizontal = report["estimator"]["rms_horizontal_m"].as_f64().unwrap();
    assert!(horizontal > 0.0 && horizontal < 1.0, "a vehicle at rest is located within a metre: {report}");
}

#[test]
fn auto_mission_flies_on_the_full_stack_and_lands_home() {
    let json = temp_path("mission.json");
    succeed(
        kestrel()
            .args(["run", "--speedup", "0", "--quiet", "--duration", "300", "--auto", "--exit-on-land"])
            .args(["--mission", "config/missions/square.plan", "--report"])
            .arg(&json),
    );
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let _ = std::fs::remove_file(&json);
    assert_eq!(report["mission"]["completed"], true, "{report:#}");
    assert_eq!(report["mission"]["items_reached"], report["mission"]["items_total"], "{report:#}");
    let flight = &report["flight"];
    assert_eq!(flight["collisions"], 0);
    assert_eq!(flight["landed"], true, "{report:#}");
    assert!(
        flight["duration_s"].as_f64().unwrap() < 120.0,
        "ended on landing, not at the time limit: {report:#}"
    );
    assert!(flight["landing_distance_from_home_m"].as_f64().unwrap() < 2.0, "{report:#}");
    assert!(report["estimator"]["rms_horizontal_m"].as_f64().unwrap() < 1.0, "{report:#}");
    assert!(report["estimator"]["rms_vertical_m"].as_f64().unwrap() < 0.5, "geodetic height: {report:#}");
    let tracking = flight["tracking_error_max_m"].as_f64().unwrap();
    assert!(tracking > 0.0 && tracking < 3.0, "cross-track error along the legs: {report:#}");
    assert_eq!(report["control"]["overruns"], 0, "{report:#}");
    assert!(report["failsafes"].as_array().unwrap().is_empty(), "{report:#}");
}

#[test]
fn perception_chain_turns_rendered_frames_into_grids_and_avoidance_commands() {
    use kestrel_proto::messages::{AvoidanceCommand, DepthGrid};
    let path = temp_path("perception.mcap");
    let out = kestrel()
        .args([
            "run",
            "--config",
            "config/perception-sim.toml",
            "--duration",
            "2",
            "--speedup",
            "0",
            "--quiet",
        ])
        .arg("--record")
        .arg(&path)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let log = LogReader::open(&path).unwrap();
    let grids = read::<DepthGrid>(&log, "depth_grid");
    let commands = read::<AvoidanceCommand>(&log, "avoidance_command");
    let _ = std::fs::remove_file(&path);
    assert!((28..=31).contains(&grids.len()), "15 Hz for 2 s, got {}", grids.len());
    assert!(commands.len() >= grids.len(), "one command per grid (plus staleness checks)");
    // At home on the ground, the nearest thing ahead is the tree 15 m north (0.6 m radius, so
    // 14.4 m to its bark, about 2 px of disparity): nothing is within the 5 m threshold, and the
    // centre region ranges the trunk.
    let last = &grids.last().unwrap().message;
    assert!(last.regions.iter().flatten().all(|r| r.near_share == 0.0), "{:?}", last.regions);
    let trunk = last.regions[1][1].nearest_m.expect("the centre region sees the tree");
    assert!((10.0..17.0).contains(&trunk), "tree ranged at {trunk} m");
}

/// `kestrel run` on the default config prints no warning and no error from start to a clean
/// stop: what a new user sees first is quiet. Run in a network namespace of its own (`unshare
/// --net` through a user namespace), so the default config's fixed UDP ports (18570, 14580) are
/// not taken by another vehicle of the suite running beside it.
#[test]
fn a_clean_start_of_the_default_graph_prints_no_warning() {
    let out = Command::new("unshare")
        .args([
            "--net",
            "--map-root-user",
            "sh",
            "-c",
            "ip link set lo up && exec \"$0\" run --duration 20 --speedup 0 --quiet",
        ])
        .arg(env!("CARGO_BIN_EXE_kestrel"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env_remove("RUST_LOG")
        .output()
        .expect("unshare (util-linux)");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let loud: Vec<&str> = stderr.lines().filter(|l| l.contains(" WARN ") || l.contains(" ERROR ")).collect();
    assert!(loud.is_empty(), "a clean start warned:\n{}", loud.join("\n"));
    assert!(stderr.contains("estimator aligned"), "the run did not get as far as alignment:\n{stderr}");
}
