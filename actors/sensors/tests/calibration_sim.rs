//! The simulator's own sensor errors, recovered by the calibration cores: a vehicle file with
//! the issue's errors under their documented names (`[sensors] board_rotation_deg`,
//! `[sensors.imu] accel_offset_m_s2`, `accel_scale`, `[sensors.mag] hard_iron_gauss`,
//! `soft_iron`) is set down still in six orientations and turned through the sphere, as a
//! person would; the fits must give back what the file put in, and the calibrated readings the
//! airframe's true field and specific force.

use kestrel_proto::Time;
use kestrel_proto::calibration::{MagCalibration, SensorCalibration, matrix3};
use kestrel_proto::messages::{ImuSample, MagSample};
use kestrel_sensors::calibration::{
    AccelSettings, GyroSettings, LevelSettings, MagCalError, MagSettings, OrientationSamples,
    VehicleOrientation, calibrate_accel, calibrate_gyro, calibrate_level, calibrate_mag,
};
use kestrel_sim::{InitialState, RigidBodyState, SimOptions, SimOutput, Simulator, VehicleParams, World};
use nalgebra::{UnitQuaternion, Vector3};
use std::f64::consts::{FRAC_PI_2, PI};

const VEHICLE: &str = r#"
[sensors]
board_rotation_deg = [2.0, -2.24, 0.0]

[sensors.imu]
accel_offset_m_s2 = [0.3, -0.3, 0.3]
accel_scale = [1.02, 0.98, 1.02]
gyro_bias_initial_rad_s = [0.01, -0.02, 0.015]

[sensors.mag]
hard_iron_gauss = [0.15, -0.1, 0.2]
soft_iron = [[1.10, 0.05, -0.05], [0.05, 0.90, 0.05], [-0.05, 0.05, 1.05]]
"#;

fn vehicle() -> VehicleParams {
    let dir = std::env::temp_dir().join(format!("kestrel-calibration-sim-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("miscalibrated.toml");
    std::fs::write(&path, VEHICLE).expect("write the vehicle file");
    VehicleParams::load(&path).expect("the vehicle file loads")
}

/// What the sensors release over `seconds` with the vehicle resting at `attitude`.
fn rest(
    vehicle: &VehicleParams,
    attitude: UnitQuaternion<f64>,
    seconds: f64,
    seed: u64,
) -> (Vec<ImuSample>, Vec<MagSample>) {
    rest_in(&World::default(), vehicle, attitude, seconds, seed, None)
}

/// The same, with `calibration` applied by the simulator's sensor path.
fn rest_calibrated(
    vehicle: &VehicleParams,
    attitude: UnitQuaternion<f64>,
    seconds: f64,
    seed: u64,
    calibration: Option<&SensorCalibration>,
) -> (Vec<ImuSample>, Vec<MagSample>) {
    rest_in(&World::default(), vehicle, attitude, seconds, seed, calibration)
}

/// The same in `world`.
fn rest_in(
    world: &World,
    vehicle: &VehicleParams,
    attitude: UnitQuaternion<f64>,
    seconds: f64,
    seed: u64,
    calibration: Option<&SensorCalibration>,
) -> (Vec<ImuSample>, Vec<MagSample>) {
    let options = SimOptions {
        seed,
        initial: InitialState {
            body: RigidBodyState { attitude, ..Default::default() },
            ..Default::default()
        },
        ..SimOptions::default()
    };
    let mut sim = Simulator::new(vehicle.clone(), world.clone(), options).expect("valid simulator");
    if let Some(calibration) = calibration {
        sim.set_calibration(calibration.clone());
    }
    sim.advance_to(Time::from_secs_f64(seconds));
    let (mut imu, mut mag) = (Vec::new(), Vec::new());
    for output in sim.drain() {
        match output {
            SimOutput::Imu(s) => imu.push(s),
            SimOutput::Mag(s) => mag.push(s),
            _ => {}
        }
    }
    (imu, mag)
}

fn attitude_of(orientation: VehicleOrientation) -> UnitQuaternion<f64> {
    let (roll, pitch) = match orientation {
        VehicleOrientation::Level => (0.0, 0.0),
        VehicleOrientation::LeftSideDown => (-FRAC_PI_2, 0.0),
        VehicleOrientation::RightSideDown => (FRAC_PI_2, 0.0),
        VehicleOrientation::NoseDown => (0.0, -FRAC_PI_2),
        VehicleOrientation::NoseUp => (0.0, FRAC_PI_2),
        VehicleOrientation::UpsideDown => (PI, 0.0),
    };
    UnitQuaternion::from_euler_angles(roll, pitch, 0.3)
}

/// Attitudes spread over the sphere (a Fibonacci spiral of "down" directions, each with its
/// own heading), as a person turns the vehicle for compass calibration.
fn tumble(count: usize) -> impl Iterator<Item = UnitQuaternion<f64>> {
    let golden = PI * (3.0 - 5f64.sqrt());
    (0..count).map(move |i| {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / count as f64;
        let r = (1.0 - z * z).sqrt();
        let down = Vector3::new(r * (golden * i as f64).cos(), r * (golden * i as f64).sin(), z);
        let tilt =
            UnitQuaternion::rotation_between(&Vector3::z(), &down).unwrap_or_else(UnitQuaternion::identity);
        tilt * UnitQuaternion::from_euler_angles(0.0, 0.0, i as f64 * 2.4)
    })
}

fn calibrate(vehicle: &VehicleParams) -> SensorCalibration {
    let field = World::default().magnetic_field.total_intensity_gauss;
    let mag_samples: Vec<MagSample> =
        tumble(400).enumerate().flat_map(|(i, q)| rest(vehicle, q, 0.025, 100 + i as u64).1).collect();
    let mag = calibrate_mag(&mag_samples, &MagSettings::new(field)).expect("compass calibration");
    let h = mag.calibration.hard_iron_gauss();
    let s = mag.calibration.soft_iron();
    let h_error = (Vector3::from(h) - Vector3::from(vehicle.sensors.mag.hard_iron_gauss)).abs().max();
    let s_error = (matrix3(&s) - matrix3(&vehicle.sensors.mag.soft_iron)).abs().max();
    eprintln!(
        "sim compass: {} samples, hard iron {h:?} G (max error {h_error:.5} G), soft iron {s:?} (max element error {s_error:.5}), residual {:.5} G, fitted field {:.4} G vs {field} G expected, {} of 32 regions",
        mag.samples, mag.residual_gauss, mag.fitted_field_gauss, mag.regions_covered
    );
    assert!(h_error < 0.02 * 0.25, "hard iron {h:?}");
    assert!(s_error < 0.0025, "soft iron {s:?}");

    let windows: Vec<(VehicleOrientation, Vec<ImuSample>)> = VehicleOrientation::ALL
        .iter()
        .enumerate()
        .map(|(i, &o)| (o, rest(vehicle, attitude_of(o), 2.0, 10 + i as u64).0))
        .collect();
    let captures: Vec<OrientationSamples<'_>> = windows
        .iter()
        .map(|(orientation, samples)| OrientationSamples { orientation: *orientation, samples })
        .collect();
    let accel = calibrate_accel(&captures, &AccelSettings::default()).expect("accelerometer calibration");
    let (offset, scale) = (accel.calibration.offset_m_s2(), accel.calibration.scale());
    let imu = &vehicle.sensors.imu;
    let offset_error = (0..3).map(|i| (offset[i] - imu.accel_offset_m_s2[i]).abs()).fold(0.0, f64::max);
    let scale_error = (0..3).map(|i| (scale[i] - imu.accel_scale[i]).abs()).fold(0.0, f64::max);
    eprintln!(
        "sim accelerometer: offset {offset:?} m/s² (max error {offset_error:.5}), scale {scale:?} (max error {scale_error:.6}), residual {:.5} m/s², misalignment {:.3}°",
        accel.residual_m_s2, accel.misalignment_deg
    );
    assert!(offset_error < 0.05 * 0.3, "{offset:?}");
    assert!(scale_error < 0.05 * 0.02, "{scale:?}");

    let (level_samples, _) = rest(vehicle, UnitQuaternion::identity(), 3.0, 20);
    let gyro = calibrate_gyro(&level_samples, &GyroSettings::default()).expect("gyro calibration");
    let g = gyro.calibration.gyro_offset_rad_s;
    let g_error = (0..3).map(|i| (g[i] - imu.gyro_bias_initial_rad_s[i]).abs()).fold(0.0, f64::max);
    eprintln!("sim gyro: offset {g:?} rad/s (max error {g_error:.6})");
    assert!(g_error < 0.05 * 0.01, "{g:?}");

    let level =
        calibrate_level(&level_samples, &accel.calibration, &LevelSettings::default()).expect("level");
    let [roll, pitch, _] = vehicle.sensors.board_rotation_deg;
    eprintln!(
        "sim level: roll {:.4}° pitch {:.4}° (file {roll}°, {pitch}°), tilt {:.4}°",
        level.level.roll_deg(),
        level.level.pitch_deg(),
        level.tilt_deg
    );
    assert!((level.level.roll_deg() - roll).abs() < 0.05 * roll.abs(), "{:?}", level.level);
    assert!((level.level.pitch_deg() - pitch).abs() < 0.05 * pitch.abs(), "{:?}", level.level);
    SensorCalibration {
        mag: mag.calibration,
        accel: accel.calibration,
        gyro: gyro.calibration,
        level: level.level,
    }
}

#[test]
fn the_simulators_sensor_errors_are_recovered_and_calibrated_readings_are_true() {
    let vehicle = vehicle();
    assert_eq!(vehicle.sensors.mag.hard_iron_gauss, [0.15, -0.1, 0.2]);
    let cal = calibrate(&vehicle);

    // A new attitude, not one calibrated at: the calibrated readings must match the truth in
    // the airframe; the raw ones do not.
    let attitude = UnitQuaternion::from_euler_angles(0.2, -0.15, 1.0);
    let (imu, mag) = rest(&vehicle, attitude, 1.0, 30);
    let field_body = attitude.inverse_transform_vector(&World::default().magnetic_field.ned_gauss());
    let mean =
        |v: &[[f64; 3]]| v.iter().fold(Vector3::zeros(), |a, x| a + Vector3::from(*x)) / v.len() as f64;
    let raw_mag = mean(&mag.iter().map(|m| m.field_gauss).collect::<Vec<_>>());
    let calibrated_mag =
        mean(&mag.iter().map(|m| cal.level.apply(cal.mag.apply(m.field_gauss))).collect::<Vec<_>>());
    let gravity_body =
        attitude.inverse_transform_vector(&Vector3::new(0.0, 0.0, -kestrel_proto::units::GRAVITY_M_S2));
    let raw_accel = mean(&imu.iter().map(|s| s.accel_m_s2).collect::<Vec<_>>());
    let calibrated_accel =
        mean(&imu.iter().map(|s| cal.level.apply(cal.accel.apply(s.accel_m_s2))).collect::<Vec<_>>());
    let calibrated_gyro =
        mean(&imu.iter().map(|s| cal.level.apply(cal.gyro.apply(s.gyro_rad_s))).collect::<Vec<_>>());
    let deg = |a: &Vector3<f64>, b: &Vector3<f64>| a.angle(b).to_degrees();
    eprintln!(
        "field direction error: raw {:.2}°, calibrated {:.3}°; |field| raw {:.4} G, calibrated {:.4} G, true {:.4} G",
        deg(&raw_mag, &field_body),
        deg(&calibrated_mag, &field_body),
        raw_mag.norm(),
        calibrated_mag.norm(),
        field_body.norm()
    );
    eprintln!(
        "gravity direction error: raw {:.3}°, calibrated {:.4}°; calibrated gyro at rest {:.5} rad/s",
        deg(&raw_accel, &gravity_body),
        deg(&calibrated_accel, &gravity_body),
        calibrated_gyro.norm()
    );
    assert!(deg(&raw_mag, &field_body) > 10.0);
    assert!(deg(&calibrated_mag, &field_body) < 1.0);
    assert!((calibrated_mag.norm() / field_body.norm() - 1.0).abs() < 0.02);
    assert!(deg(&calibrated_accel, &gravity_body) < 0.1);
    assert!(calibrated_gyro.norm() < 0.001);

    // The simulator's sensor path applies the same calibration the same way.
    let (sim_imu, sim_mag) = rest_calibrated(&vehicle, attitude, 1.0, 30, Some(&cal));
    assert_eq!(sim_imu, imu.iter().map(|s| cal.apply_imu(s)).collect::<Vec<_>>());
    assert_eq!(sim_mag, mag.iter().map(|m| cal.apply_mag(m)).collect::<Vec<_>>());
    assert!(
        sim_mag.iter().all(|m| (Vector3::from(m.field_gauss).norm() / field_body.norm() - 1.0).abs() < 0.1)
    );
}

#[test]
fn a_simulated_vehicle_held_in_one_orientation_is_refused() {
    let (_, mag) = rest(&vehicle(), UnitQuaternion::from_euler_angles(0.1, 0.2, 0.3), 5.0, 40);
    let err = calibrate_mag(&mag, &MagSettings::new(0.41)).unwrap_err();
    eprintln!("{} samples in one orientation: {err}", mag.len());
    assert!(matches!(err, MagCalError::NoSpread { .. }), "{err}");
}

#[test]
fn the_default_vehicle_needs_no_calibration() {
    let vehicle = VehicleParams::default();
    assert_eq!(vehicle.sensors.board_rotation_deg, [0.0; 3]);
    assert_eq!(vehicle.sensors.imu.accel_offset_m_s2, [0.0; 3]);
    assert_eq!(vehicle.sensors.imu.accel_scale, [1.0; 3]);
    assert_eq!(vehicle.sensors.mag.soft_iron, MagCalibration::identity().soft_iron());
    let windows: Vec<(VehicleOrientation, Vec<ImuSample>)> =
        VehicleOrientation::ALL.iter().map(|&o| (o, rest(&vehicle, attitude_of(o), 1.0, 50).0)).collect();
    let captures: Vec<OrientationSamples<'_>> = windows
        .iter()
        .map(|(orientation, samples)| OrientationSamples { orientation: *orientation, samples })
        .collect();
    let fit = calibrate_accel(&captures, &AccelSettings::default()).expect("accelerometer calibration");
    eprintln!(
        "default vehicle: offset {:?}, scale {:?}",
        fit.calibration.offset_m_s2(),
        fit.calibration.scale()
    );
    assert!(fit.calibration.offset_m_s2().iter().all(|o| o.abs() < 0.01));
    assert!(fit.calibration.scale().iter().all(|s| (s - 1.0).abs() < 0.001));
}

#[test]
fn a_simulated_field_three_times_the_earths_is_refused() {
    let mut world = World::default();
    world.magnetic_field.total_intensity_gauss *= 3.0;
    let vehicle = vehicle();
    let samples: Vec<MagSample> = tumble(300)
        .enumerate()
        .flat_map(|(i, q)| rest_in(&world, &vehicle, q, 0.025, 200 + i as u64, None).1)
        .collect();
    let expected = World::default().magnetic_field.total_intensity_gauss;
    let err = calibrate_mag(&samples, &MagSettings::new(expected)).unwrap_err();
    eprintln!(
        "a field of {:.2} G against {expected} G expected: {err}",
        world.magnetic_field.total_intensity_gauss
    );
    assert!(matches!(err, MagCalError::FieldStrength { ratio, .. } if ratio > 2.5), "{err}");
}
