//! Issue 19's acceptance: a pymavlink ground station (tests/python/gcs_calibration.py) calibrates
//! a simulated vehicle with sensor errors (config/vehicles/quad_x_miscalibrated.toml: hard iron
//! (0.15, −0.1, 0.2) G, soft iron with 10 % scale and 5 % cross terms, accelerometer offsets
//! 0.3 m/s² and 2 % scale, the board tilted 3°) over MAVLink — accelerometer, level, compass —
//! against `kestrel run` as a child process, with the calibration required before arming.
//! Arming is refused first with the STATUSTEXT naming the step; the recovered parameters lie
//! within 5 % / 0.02 G of the vehicle file's truth. Without a restart (the estimator aligns
//! again on the new calibration) the ground station flies the square mission, and the yaw error
//! it measures (ATTITUDE against the simulator's SIMSTATE) must be within 1° of the same
//! flight's on a vehicle without sensor errors. After a restart the parameters are still there
//! and arming is accepted. The square is also flown in-process, error-free, uncalibrated and
//! calibrated from the parameter file, for the figure without calibration.

mod sim_vehicle;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use kestrel::{LoadedConfig, Registry, RunOptions, run};
use kestrel_proto::calibration::{CalibrationParams, SensorCalibration};
use sim_vehicle::{PARAM_TABLE, Proc, python_client, root, sim_config, stop, tail, temp_dir};

const VEHICLE: &str = "config/vehicles/quad_x_miscalibrated.toml";
const ERROR_FREE: &str = "config/vehicles/quad_x.toml";
const CLIENT_LIMIT: Duration = Duration::from_secs(150);

/// The calibration graph: config/sim.toml with `vehicle`, the calibration required when
/// `required`, and the link's parameters persisted in `dir`.
fn config(port: u16, dir: &Path, vehicle: &str, required: bool) -> String {
    let link = format!(
        "params.system_id = 1\nparams.param_file = \"{}\"\nparams.endpoints = [ {{ type = \"udp_out\", address = \"127.0.0.1:{port}\" }} ]\nparams.params = {PARAM_TABLE}\n",
        dir.join("params.txt").display()
    );
    let text = sim_config(&link);
    let default = format!("vehicle = \"{}\"", root().join(ERROR_FREE).display());
    assert!(text.contains(&default), "config/sim.toml names vehicles/quad_x.toml");
    let with_vehicle = text.replace(&default, &format!("vehicle = \"{}\"", root().join(vehicle).display()));
    if !required {
        return with_vehicle;
    }
    let required = with_vehicle.replace("required = []", "required = [\"accel\", \"level\", \"compass\"]");
    assert_ne!(required, with_vehicle, "config/sim.toml's calibration has `required = []`");
    required
}

/// Runs the pymavlink client in `scenario` against `kestrel run` on `vehicle` (calibration
/// `required` or not); returns its results JSON.
fn session(dir: &Path, scenario: &str, vehicle: &str, required: bool) -> serde_json::Value {
    let plan = root().join("config/missions/square.plan");
    client_session(
        dir,
        scenario,
        vehicle,
        required,
        "gcs_calibration.py",
        &[("CAL_SCENARIO", scenario.into()), ("CAL_PLAN", plan.display().to_string())],
    )
}

/// Runs `script` (its environment `env`) against `kestrel run` on `vehicle`; returns the results
/// JSON of its last line.
fn client_session(
    dir: &Path,
    scenario: &str,
    vehicle: &str,
    required: bool,
    script: &str,
    env: &[(&str, String)],
) -> serde_json::Value {
    let (mut client, lines) = python_client(script, |c| c.envs(env.iter().map(|(k, v)| (k, v))));
    let first = lines.recv_timeout(Duration::from_secs(15)).unwrap_or_default();
    let port: u16 = first.strip_prefix("PORT ").and_then(|p| p.trim().parse().ok()).expect("client port");
    let config_path = dir.join(format!("{scenario}.toml"));
    std::fs::write(&config_path, config(port, dir, vehicle, required)).expect("config");
    let log_path = dir.join(format!("{scenario}.log"));
    let mut kestrel = Proc(
        Command::new(env!("CARGO_BIN_EXE_kestrel"))
            .current_dir(dir)
            .env_remove("RUST_LOG")
            .args(["run", "--quiet", "--speedup", "5", "--duration", "600", "--config"])
            .arg(&config_path)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log_path).expect("log"))
            .spawn()
            .expect("start kestrel run"),
    );
    println!("── {scenario} ──");
    let started = Instant::now();
    let mut transcript = Vec::new();
    let exit = loop {
        while let Ok(line) = lines.recv_timeout(Duration::from_millis(50)) {
            println!("  {line}");
            transcript.push(line);
        }
        if let Some(status) = client.0.try_wait().expect("client status") {
            transcript.extend(lines.try_iter());
            break Some(status);
        }
        if started.elapsed() > CLIENT_LIMIT {
            break None;
        }
    };
    let log = || tail(&std::fs::read_to_string(&log_path).unwrap_or_default(), 30);
    assert!(exit.is_some_and(|s| s.success()), "{scenario}: client {exit:?}\n{}", log());
    assert!(stop(&mut kestrel, scenario).success(), "{scenario}: kestrel failed\n{}", log());
    let last = transcript.last().expect("a result line");
    let result: serde_json::Value = serde_json::from_str(last).expect("JSON result");
    result["results"].clone()
}

/// Checks `got` against the vehicle file's truth (config/vehicles/quad_x_miscalibrated.toml):
/// within 5 % of each error (0.02 G of the hard iron, 0.015 m/s² of the offsets, 0.001 of the
/// scales, 0.1° of the tilt).
fn assert_recovers_the_truth(got: &SensorCalibration) {
    let hard = got.mag.hard_iron_gauss();
    let soft = got.mag.soft_iron();
    let truth_soft = [[1.10, 0.05, -0.05], [0.05, 0.90, 0.05], [-0.05, 0.05, 1.05]];
    println!("hard iron {hard:?} G, soft iron {soft:?}");
    for (h, t) in hard.iter().zip([0.15, -0.1, 0.2]) {
        assert!((h - t).abs() <= 0.02, "hard iron {hard:?}");
    }
    for (row, truth_row) in soft.iter().zip(truth_soft) {
        for (s, t) in row.iter().zip(truth_row) {
            assert!((s - t).abs() <= 0.05, "soft iron {soft:?}");
        }
    }
    let (offset, scale) = (got.accel.offset_m_s2(), got.accel.scale());
    println!("accel offset {offset:?} m/s², scale {scale:?}");
    for (o, t) in offset.iter().zip([0.3, -0.3, 0.3]) {
        assert!((o - t).abs() <= 0.05 * 0.3, "accel offset {offset:?}");
    }
    for (s, t) in scale.iter().zip([1.02, 0.98, 1.02]) {
        assert!((s - t).abs() <= 0.05 * 0.02, "accel scale {scale:?}");
    }
    let (roll, pitch) = (got.level.roll_deg(), got.level.pitch_deg());
    println!("board level roll {roll:.3}°, pitch {pitch:.3}°");
    assert!((roll - 2.0).abs() <= 0.1 && (pitch + 2.24).abs() <= 0.112, "level {roll} {pitch}");
}

/// The calibration the parameters read over MAVLink hold.
fn calibration_of(params: &serde_json::Value) -> SensorCalibration {
    let map = params.as_object().expect("parameters");
    let p = map.iter().fold(CalibrationParams::default(), |p, (k, v)| p.with(k, v.as_f64().expect("number")));
    p.calibration().expect("valid calibration")
}

/// Flies config/missions/square.plan in-process on `vehicle` with the parameter file
/// `param_file` (if any); returns the report's `estimator.rms_yaw_deg`.
fn square_yaw_deg(dir: &Path, label: &str, vehicle: &str, param_file: Option<&Path>) -> f64 {
    let config_dir = root().join("config");
    let mut config = LoadedConfig::load(&config_dir.join("sim.toml")).expect("sim.toml");
    let table = |pairs: Vec<(&str, toml::Value)>| -> toml::Table {
        pairs.into_iter().map(|(k, v)| (k.to_owned(), v)).collect()
    };
    for actor in config.graph.actors.values_mut() {
        let params = match actor.kind.get_ref().as_str() {
            "commander" => table(vec![
                ("mission", config_dir.join("missions/square.plan").display().to_string().into()),
                ("auto", true.into()),
                ("exit_on_land", true.into()),
            ]),
            "sim" => table(vec![
                ("vehicle", root().join(vehicle).display().to_string().into()),
                ("world", config_dir.join("worlds/empty.toml").display().to_string().into()),
                ("seed", 1.into()),
            ]),
            "link" => {
                let mut t = table(vec![("endpoints", toml::Value::Array(Vec::new()))]);
                if let Some(file) = param_file {
                    t.insert("param_file".into(), file.display().to_string().into());
                }
                t
            }
            _ => continue,
        };
        actor.params = Some(toml::Spanned::new(0..0, params));
    }
    let report_path = dir.join(format!("{label}-report.json"));
    let options = RunOptions {
        duration: Some(Duration::from_secs(200)),
        speedup: Some(0.0),
        report: Some(report_path.clone()),
        ..Default::default()
    };
    run(&config, &Registry::standard(), options).expect("the flight ran");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report_path).expect("report")).expect("JSON");
    assert_eq!(report["mission"]["completed"], true, "{label}: {report:#}");
    let yaw = report["estimator"]["rms_yaw_deg"].as_f64().expect("rms_yaw_deg");
    println!("{label}: rms_yaw_deg {yaw:.3}, estimator {}", report["estimator"]);
    yaw
}

#[test]
fn a_ground_station_calibrates_the_vehicle_and_its_yaw_error_drops_to_the_error_free_one() {
    let dir = temp_dir("calibration");
    let first = session(&dir, "calibrate", VEHICLE, true);
    let refusal = first["prearm_refusal"].as_str().expect("a pre-arm STATUSTEXT");
    assert_eq!(refusal, "PreArm: 3D Accel calibration needed");
    assert_eq!(first["accel_positions"], serde_json::json!([1, 2, 3, 4, 5, 6]));
    assert_eq!(calibration_of(&first["before"]), SensorCalibration::default(), "nothing calibrated before");

    assert_recovers_the_truth(&calibration_of(&first["params"]));

    // Flown without a restart, measured by the ground station against SIMSTATE, beside the
    // same flight of a vehicle without sensor errors (parameters of its own).
    let reference_dir = dir.join("reference");
    std::fs::create_dir_all(&reference_dir).expect("reference dir");
    let reference = session(&reference_dir, "reference", ERROR_FREE, false);
    let yaw = |session: &serde_json::Value| session["flight"]["rms_yaw_deg"].as_f64().expect("rms_yaw_deg");
    let (gcs_free, gcs_calibrated) = (yaw(&reference), yaw(&first));
    println!(
        "ground station's rms yaw error: error-free {gcs_free:.3}°, calibrated without a restart {gcs_calibrated:.3}°"
    );
    for flight in [&reference["flight"], &first["flight"]] {
        assert!(flight["yaw_samples"].as_u64().expect("samples") > 100, "{flight}");
        assert!(flight["landed_from_home_m"].as_f64().expect("landing") < 3.0, "{flight}");
    }
    assert!(
        (gcs_calibrated - gcs_free).abs() <= 1.0,
        "calibrated {gcs_calibrated}° vs error-free {gcs_free}°"
    );

    // A restart keeps every value and arming is accepted.
    let second = session(&dir, "verify", VEHICLE, true);
    assert_eq!(second["params"], first["params"], "the parameters survived the restart");
    assert_eq!(second["armed"], true);

    let free = square_yaw_deg(&dir, "error-free", ERROR_FREE, None);
    let raw = square_yaw_deg(&dir, "uncalibrated", VEHICLE, None);
    let calibrated = square_yaw_deg(&dir, "calibrated", VEHICLE, Some(&dir.join("params.txt")));
    println!("rms_yaw_deg: error-free {free:.3}, uncalibrated {raw:.3}, calibrated {calibrated:.3}");
    assert!(raw > free + 2.0, "the sensor errors show in the yaw error: {raw} vs {free}");
    assert!((calibrated - free).abs() <= 1.0, "calibrated {calibrated} vs error-free {free}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn mavproxy_calibrates_the_vehicle_as_an_operator_types_it() {
    let dir = temp_dir("calibration-mavproxy");
    let env = [("MAVPROXY_SCENARIO", "calibrate".to_owned())];
    let result = client_session(&dir, "mavproxy", VEHICLE, true, "mavproxy_session.py", &env);
    assert_eq!(result["prearm_refusal"], "PreArm: 3D Accel calibration needed");
    let positions = result["accel_positions"].as_array().expect("positions");
    assert_eq!(positions.len(), 6, "{positions:?}");
    println!("MAVProxy: positions {positions:?}, compass fitness {} mG", result["mag_fitness_mgauss"]);
    assert_recovers_the_truth(&calibration_of(&result["params"]));
    assert_eq!(result["armed_after"], true);
    let _ = std::fs::remove_dir_all(&dir);
}
