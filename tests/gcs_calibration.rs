//! A pymavlink ground station (tests/python/gcs_calibration.py) calibrates
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

mod support;
use support::sim_vehicle;

use std::path::Path;

use kestrel_proto::calibration::{CalibrationParams, SensorCalibration};
use sim_vehicle::{
    on_vehicle, root, scripted_session, session_link, sim_config, square_in_process, temp_dir,
};

const VEHICLE: &str = "config/vehicles/quad_x_miscalibrated.toml";
const ERROR_FREE: &str = "config/vehicles/quad_x.toml";

/// The calibration graph: config/sim.toml with `vehicle`, the calibration required when
/// `required`, and the link's parameters persisted in `dir`.
fn config(port: u16, dir: &Path, vehicle: &str, required: bool) -> String {
    let with_vehicle = on_vehicle(&sim_config(&session_link(port, dir)), vehicle);
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
    let env = [("CAL_SCENARIO", scenario.to_owned()), ("CAL_PLAN", plan.display().to_string())];
    scripted_session(dir, scenario, "gcs_calibration.py", &env, |port| config(port, dir, vehicle, required))["results"]
        .clone()
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
    let report = square_in_process(dir, label, vehicle, param_file, None);
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
    let config = |port| config(port, &dir, VEHICLE, true);
    let result = scripted_session(&dir, "mavproxy", "mavproxy_session.py", &env, config)["results"].clone();
    assert_eq!(result["prearm_refusal"], "PreArm: 3D Accel calibration needed");
    let positions = result["accel_positions"].as_array().expect("positions");
    assert_eq!(positions.len(), 6, "{positions:?}");
    println!("MAVProxy: positions {positions:?}, compass fitness {} mG", result["mag_fitness_mgauss"]);
    assert_recovers_the_truth(&calibration_of(&result["params"]));
    assert_eq!(result["armed_after"], true);
    let _ = std::fs::remove_dir_all(&dir);
}
