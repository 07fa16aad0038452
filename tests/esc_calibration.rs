//! Issue 19's last item: the ESC range calibration over MAVLink. A pymavlink ground station
//! (tests/python/gcs_esc_calibration.py) sends PREFLIGHT_CALIBRATION param7 = 1 to `kestrel run`
//! (a child process) on a simulated vehicle whose four ESCs have ranges of their own
//! (config/vehicles/quad_x_unequal_escs.toml); it is refused while armed, cancelled by the
//! all-zero command, stopped by an arm request, then run to its end; the SERVOn_MIN/MAX read back
//! with PARAM_REQUEST_READ must lie within 5 µs of each ESC's true start and full-speed pulse.
//! Without ESC telemetry and without a battery monitor in the graph it is refused, naming what
//! is missing (the Navio2's PWM ESCs get PX4's max-then-min, which needs the battery monitor:
//! actors/sensors/tests/calibration_session.rs). The square mission is then flown in-process three times — the nominal vehicle, the
//! unequal one uncalibrated, and calibrated from the parameter file the link wrote — and the
//! spread of the four motors' mean commands in the air (what the controller spends on making
//! unequal ESCs push alike) is measured for each.

mod sim_vehicle;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use kestrel::recorder::LogReader;
use kestrel::{LoadedConfig, Registry, RunOptions, run};
use kestrel_proto::messages::ActuatorOutputs;
use sim_vehicle::{PARAM_TABLE, Proc, python_client, root, sim_config, stop, tail, temp_dir};

const VEHICLE: &str = "config/vehicles/quad_x_unequal_escs.toml";
const CLIENT_LIMIT: Duration = Duration::from_secs(150);
/// What the vehicle file says (µs): each ESC's [start, full].
const TRUTH_US: [[f64; 2]; 4] = [[1083.0, 1917.0], [1047.0, 1951.0], [1118.0, 1886.0], [1062.0, 1934.0]];

/// config/sim.toml on the unequal-ESC vehicle, the link sending to `port`; without any route of
/// `esc_telemetry` unless `telemetry`.
fn config(port: u16, dir: &Path, telemetry: bool) -> String {
    let link = format!(
        "params.system_id = 1\nparams.param_file = \"{}\"\nparams.endpoints = [ {{ type = \"udp_out\", address = \"127.0.0.1:{port}\" }} ]\nparams.params = {PARAM_TABLE}\n",
        dir.join("params.txt").display()
    );
    let text = sim_config(&link);
    let default = format!("vehicle = \"{}\"", root().join("config/vehicles/quad_x.toml").display());
    assert!(text.contains(&default), "config/sim.toml names vehicles/quad_x.toml");
    let text = text.replace(&default, &format!("vehicle = \"{}\"", root().join(VEHICLE).display()));
    if telemetry {
        return text;
    }
    let mut graph: toml::Table = toml::from_str(&text).expect("the merged graph");
    for actor in ["calibration", "commander"] {
        let inputs = graph["actors"][actor]["inputs"].as_table().map(|t| t.contains_key("esc_telemetry"));
        assert_eq!(inputs, Some(true), "config/sim.toml routes esc_telemetry to the {actor}");
        if let Some(inputs) = graph
            .get_mut("actors")
            .and_then(|a| a.get_mut(actor))
            .and_then(|a| a.get_mut("inputs"))
            .and_then(|i| i.as_table_mut())
        {
            inputs.remove("esc_telemetry");
        }
    }
    toml::to_string(&graph).expect("TOML")
}

/// Runs the client in `scenario` against `kestrel run`; returns its results JSON.
fn session(dir: &Path, scenario: &str, telemetry: bool) -> serde_json::Value {
    let (mut client, lines) = python_client("gcs_esc_calibration.py", |c| c.env("ESC_SCENARIO", scenario));
    let first = lines.recv_timeout(Duration::from_secs(15)).unwrap_or_default();
    let port: u16 = first.strip_prefix("PORT ").and_then(|p| p.trim().parse().ok()).expect("client port");
    let config_path = dir.join(format!("{scenario}.toml"));
    std::fs::write(&config_path, config(port, dir, telemetry)).expect("config");
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
    let result: serde_json::Value =
        serde_json::from_str(transcript.last().expect("a result line")).expect("JSON result");
    assert_eq!(result["ok"], true, "{scenario}: {result}\n{}", log());
    println!("{scenario} took {:.1} s", started.elapsed().as_secs_f64());
    result["results"].clone()
}

#[test]
fn a_ground_station_calibrates_each_escs_range_and_reads_it_back() {
    let dir = temp_dir("esc-calibrate");
    let results = session(&dir, "calibrate", true);
    let param =
        |set: &str, name: String| results[set][&name].as_f64().unwrap_or_else(|| panic!("{set} {name}"));
    for i in 1..=4 {
        assert_eq!(
            (param("before", format!("SERVO{i}_MIN")), param("before", format!("SERVO{i}_MAX"))),
            (1000.0, 2000.0),
            "uncalibrated outputs start nominal"
        );
    }
    let armed = results["armed_refusal"]["text"].as_str().expect("armed refusal");
    assert!(armed.contains("armed"), "{armed}");
    for (i, [start, full]) in TRUTH_US.iter().enumerate() {
        let (min, max) =
            (param("params", format!("SERVO{}_MIN", i + 1)), param("params", format!("SERVO{}_MAX", i + 1)));
        println!(
            "ESC {}: truth {start}..{full} µs, calibrated SERVO{}_MIN/MAX {min}..{max} µs",
            i + 1,
            i + 1
        );
        assert!(
            (min - start).abs() <= 5.0 && (max - full).abs() <= 5.0,
            "ESC {}: {min}..{max} against {start}..{full}",
            i + 1
        );
    }

    let nominal = square_motor_spread(&dir, "nominal", "config/vehicles/quad_x.toml", None);
    let uncalibrated = square_motor_spread(&dir, "uncalibrated", VEHICLE, None);
    let calibrated = square_motor_spread(&dir, "calibrated", VEHICLE, Some(&dir.join("params.txt")));
    println!(
        "spread of the motors' mean commands in the air: nominal {nominal:.4}, unequal ESCs uncalibrated {uncalibrated:.4}, calibrated {calibrated:.4}"
    );
    assert!(
        calibrated < uncalibrated / 2.0,
        "calibration did not even the motors: {calibrated} vs {uncalibrated}"
    );
}

/// Flies config/missions/square.plan in-process on `vehicle` with the link's parameter file
/// `param_file` (if any), recording the actuator outputs; returns max − min over the four motors
/// of each motor's mean command while armed and above a third of full (airborne).
fn square_motor_spread(dir: &Path, label: &str, vehicle: &str, param_file: Option<&Path>) -> f64 {
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
    let record = dir.join(format!("{label}.mcap"));
    let report_path = dir.join(format!("{label}-report.json"));
    let options = RunOptions {
        duration: Some(Duration::from_secs(200)),
        speedup: Some(0.0),
        record: Some(record.clone()),
        report: Some(report_path.clone()),
        ..Default::default()
    };
    run(&config, &Registry::standard(), options).expect("the flight ran");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report_path).expect("report")).expect("JSON");
    assert_eq!(report["mission"]["completed"], true, "{label}: {report:#}");
    let outputs =
        LogReader::open(&record).expect("log").read::<ActuatorOutputs>("actuator_outputs").expect("outputs");
    let airborne: Vec<[f64; 4]> = outputs
        .iter()
        .map(|r| &r.message)
        .filter(|m| m.armed && m.motors[..4].iter().sum::<f64>() / 4.0 > 1.0 / 3.0)
        .map(|m| [m.motors[0], m.motors[1], m.motors[2], m.motors[3]])
        .collect();
    assert!(airborne.len() > 4000, "{label}: {} airborne samples", airborne.len());
    let n = airborne.len() as f64;
    let means: Vec<f64> = (0..4).map(|i| airborne.iter().map(|m| m[i]).sum::<f64>() / n).collect();
    let spread =
        means.iter().copied().fold(f64::MIN, f64::max) - means.iter().copied().fold(f64::MAX, f64::min);
    println!("{label}: mean commands {means:.4?} over {} samples, spread {spread:.4}", airborne.len());
    spread
}

#[test]
fn without_esc_telemetry_the_calibration_is_refused_naming_it() {
    let results = session(&temp_dir("esc-no-telemetry"), "no_telemetry", false);
    let refusal = &results["no_telemetry_refusal"];
    assert_ne!(refusal["result"], "MAV_RESULT_ACCEPTED", "{refusal}");
    assert!(refusal["text"].as_str().is_some_and(|t| t.contains("no ESC telemetry")), "{refusal}");
    println!("refused: {refusal}");
}
