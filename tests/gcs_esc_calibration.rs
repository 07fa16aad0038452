//! The ESC range calibration over MAVLink. A pymavlink ground station
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

mod support;
use support::sim_vehicle;

use std::path::Path;

use kestrel::recorder::LogReader;
use kestrel_proto::messages::ActuatorOutputs;
use sim_vehicle::{on_vehicle, scripted_session, session_link, sim_config, square_in_process, temp_dir};

const VEHICLE: &str = "config/vehicles/quad_x_unequal_escs.toml";
/// What the vehicle file says (µs): each ESC's [start, full].
const TRUTH_US: [[f64; 2]; 4] = [[1083.0, 1917.0], [1047.0, 1951.0], [1118.0, 1886.0], [1062.0, 1934.0]];

/// config/sim.toml on the unequal-ESC vehicle, the link sending to `port`; without any route of
/// `esc_telemetry` unless `telemetry`.
fn config(port: u16, dir: &Path, telemetry: bool) -> String {
    let text = on_vehicle(&sim_config(&session_link(port, dir)), VEHICLE);
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
    let env = [("ESC_SCENARIO", scenario.to_owned())];
    let result =
        scripted_session(dir, scenario, "gcs_esc_calibration.py", &env, |port| config(port, dir, telemetry));
    assert_eq!(result["ok"], true, "{scenario}: {result}");
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
    let record = dir.join(format!("{label}.mcap"));
    square_in_process(dir, label, vehicle, param_file, Some(record.clone()));
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
