//! Sensor acceptance tests over 60 s of simulated time at rest on the ground: rates, lags
//! (release time minus measurement stamp) and noise standard deviations against the config.

use std::collections::HashMap;

use kestrel_proto::Time;
use kestrel_proto::geo::LocalFrame;
use kestrel_proto::messages::RangefinderOrientation;
use kestrel_sim::sensors::RangefinderParams;
use kestrel_sim::sensors::baro::isa_pressure_pa;
use kestrel_sim::{Obstacle, SimOptions, SimOutput, Simulator, VehicleParams, World};

/// Everything released in `seconds`, with the time each was released at.
fn record(seconds: f64, seed: u64) -> (Simulator, Vec<(Time, SimOutput)>) {
    let options = SimOptions { seed, ..SimOptions::default() };
    let mut sim = Simulator::new(VehicleParams::default(), World::default(), options).expect("valid");
    let mut released = Vec::new();
    let end = Time::from_secs_f64(seconds);
    while sim.time() < end {
        sim.step();
        let now = sim.time();
        released.extend(sim.drain().map(|o| (now, o)));
    }
    (sim, released)
}

fn stamp(o: &SimOutput) -> (&'static str, Time) {
    match o {
        SimOutput::Imu(m) => ("imu", m.time),
        SimOutput::Imu2(m) => ("imu2", m.time),
        SimOutput::Gps(m) => ("gps", m.time),
        SimOutput::Baro(m) => ("baro", m.time),
        SimOutput::Mag(m) => ("mag", m.time),
        SimOutput::Rangefinder(m) => ("rangefinder", m.time),
        SimOutput::GroundTruth(m) => ("ground_truth", m.time),
        SimOutput::Battery(m) => ("battery", m.time),
        SimOutput::Esc(m) => ("esc_telemetry", m.time),
        SimOutput::Fault(m) => ("sim_fault", m.time),
    }
}

fn std_dev(xs: impl IntoIterator<Item = f64>) -> f64 {
    let xs: Vec<f64> = xs.into_iter().collect();
    let mean = xs.iter().sum::<f64>() / xs.len() as f64;
    (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (xs.len() - 1) as f64).sqrt()
}

fn within_5_percent(name: &str, measured: f64, configured: f64) {
    let error = (measured / configured - 1.0).abs();
    eprintln!(
        "{name}: measured {measured:.6}, configured {configured} ({:+.2} %)",
        (measured / configured - 1.0) * 100.0
    );
    assert!(
        error < 0.05,
        "{name}: measured {measured}, configured {configured} ({:.1} % off)",
        error * 100.0
    );
}

#[test]
fn rates_and_lags_match_the_config_over_60_seconds() {
    let (sim, released) = record(60.0, 1);
    let sensors = &sim.vehicle().sensors;
    let configured: HashMap<&str, (f64, f64)> = HashMap::from([
        ("imu", (sensors.imu.rate_hz, 0.0)),
        ("gps", (sensors.gps.rate_hz, sensors.gps.lag_s)),
        ("baro", (sensors.baro.rate_hz, sensors.baro.lag_s)),
        ("mag", (sensors.mag.rate_hz, sensors.mag.lag_s)),
        ("ground_truth", (50.0, 0.0)),
        ("battery", (10.0, 0.0)),
        ("esc_telemetry", (sensors.imu.rate_hz, 0.0)),
    ]);
    for (&topic, &(rate_hz, lag_s)) in &configured {
        let samples: Vec<(Time, Time)> = released
            .iter()
            .filter_map(|(at, o)| {
                let (name, stamped) = stamp(o);
                (name == topic).then_some((*at, stamped))
            })
            .collect();
        let (first, last) = (samples[0].1, samples[samples.len() - 1].1);
        let measured_rate_hz = (samples.len() - 1) as f64 / (last - first).as_secs_f64();
        within_5_percent(&format!("{topic} rate"), measured_rate_hz, rate_hz);
        assert!(
            samples.len() as f64 > 0.95 * 60.0 * rate_hz - 2.0,
            "{topic}: only {} samples",
            samples.len()
        );
        for &(released_at, stamped) in &samples {
            let lag = (released_at - stamped).as_secs_f64();
            assert!((lag - lag_s).abs() < 1e-9 + 0.05 * lag_s, "{topic}: lag {lag} s, configured {lag_s} s");
        }
        assert!(samples.windows(2).all(|w| w[0].1 < w[1].1), "{topic}: stamps not increasing");
    }
}

#[test]
fn noise_standard_deviations_match_the_config_over_60_seconds() {
    let (sim, released) = record(60.0, 2);
    let sensors = sim.vehicle().sensors.clone();
    let world = sim.world().clone();
    let frame = LocalFrame::new(world.home.geodetic());
    let field = world.magnetic_field.ned_gauss();

    // The vehicle rests level on the ground at home: the truth is known and constant. The IMU
    // biases random-walk, so its white noise is measured from successive differences (σ√2).
    let imu: Vec<_> =
        released.iter().filter_map(|(_, o)| if let SimOutput::Imu(m) = o { Some(m) } else { None }).collect();
    let diffs = |f: fn(&kestrel_proto::messages::ImuSample) -> [f64; 3]| {
        imu.windows(2).flat_map(move |w| (0..3).map(move |i| (f(w[1])[i] - f(w[0])[i]) / 2f64.sqrt()))
    };
    within_5_percent("gyro noise", std_dev(diffs(|m| m.gyro_rad_s)), sensors.imu.gyro_noise_rad_s);
    within_5_percent("accel noise", std_dev(diffs(|m| m.accel_m_s2)), sensors.imu.accel_noise_m_s2);
    let mean_accel_down = imu.iter().map(|m| m.accel_m_s2[2]).sum::<f64>() / imu.len() as f64;
    assert!((mean_accel_down + kestrel_proto::units::GRAVITY_M_S2).abs() < 0.05, "{mean_accel_down}");

    let gps: Vec<_> =
        released.iter().filter_map(|(_, o)| if let SimOutput::Gps(m) = o { Some(m) } else { None }).collect();
    let ned: Vec<[f64; 3]> = gps
        .iter()
        .map(|m| {
            frame.to_ned(kestrel_proto::geo::Geodetic {
                lat_deg: m.lat_deg,
                lon_deg: m.lon_deg,
                alt_m: m.alt_msl_m,
            })
        })
        .collect();
    let (h, v) = (sensors.gps.horizontal_noise_m, sensors.gps.vertical_noise_m);
    // 300 fixes: pool the three axes, each scaled by its configured σ, for a tighter estimate.
    let scaled = ned.iter().flat_map(|p| [p[0] / h, p[1] / h, p[2] / v]);
    within_5_percent("gps position noise (pooled, in σ)", std_dev(scaled), 1.0);
    within_5_percent("gps horizontal noise", std_dev(ned.iter().flat_map(|p| [p[0], p[1]])), h);
    let vel = gps.iter().flat_map(|m| m.vel_ned_m_s);
    within_5_percent("gps velocity noise", std_dev(vel), sensors.gps.velocity_noise_m_s);
    assert!(gps.iter().all(|m| m.h_acc_m == h && m.v_acc_m == v));

    let baro_truth_pa = isa_pressure_pa(world.home.alt_msl_m);
    let baro = released.iter().filter_map(|(_, o)| if let SimOutput::Baro(m) = o { Some(m) } else { None });
    let residuals: Vec<f64> = baro.map(|m| m.pressure_pa - baro_truth_pa).collect();
    within_5_percent("baro noise", std_dev(residuals.iter().copied()), sensors.baro.pressure_noise_pa);
    assert!(residuals.iter().sum::<f64>().abs() / (residuals.len() as f64) < 0.5);

    let mag = released.iter().filter_map(|(_, o)| if let SimOutput::Mag(m) = o { Some(m) } else { None });
    let residuals = mag.flat_map(|m| (0..3).map(move |i| m.field_gauss[i] - field[i]).collect::<Vec<_>>());
    within_5_percent("mag noise", std_dev(residuals), sensors.mag.noise_gauss);
}

#[test]
fn rangefinders_sample_at_their_rate_after_their_lag_only_when_fitted() {
    let (_, released) = record(1.0, 3);
    assert!(!released.iter().any(|(_, o)| matches!(o, SimOutput::Rangefinder(_))), "none fitted by default");

    // Landed under a 4 m-high overhang: the top one reads 4 m, the bottom one its minimum.
    let mut vehicle = VehicleParams::default();
    let tfmini = RangefinderParams::default();
    vehicle.sensors.rangefinder_up = Some(RangefinderParams { lag_s: 0.03, ..tfmini.clone() });
    vehicle.sensors.rangefinder_down = Some(RangefinderParams { rate_hz: 50.0, ..tfmini });
    let world = World {
        obstacles: vec![Obstacle::Box {
            center_ned_m: [0.0, 0.0, -5.0],
            size_m: [4.0, 4.0, 2.0],
            yaw_deg: 0.0,
        }],
        ..World::default()
    };
    let mut sim = Simulator::new(vehicle, world, SimOptions::default()).expect("valid");
    let mut samples = Vec::new();
    while sim.time() < Time::from_secs_f64(10.0) {
        sim.step();
        let now = sim.time();
        samples.extend(sim.drain().filter_map(|o| match o {
            SimOutput::Rangefinder(m) => Some((now, m)),
            _ => None,
        }));
    }
    for (orientation, rate_hz, lag_s, reads_m) in
        [(RangefinderOrientation::Up, 100.0_f64, 0.03, 4.0), (RangefinderOrientation::Down, 50.0, 0.0, 0.1)]
    {
        let mine: Vec<_> = samples.iter().filter(|(_, m)| m.orientation == orientation).collect();
        // 10 s at the rate, less the ones still in their lag.
        assert_eq!(mine.len() as f64, (10.0 * rate_hz - lag_s * rate_hz).round(), "{orientation:?}");
        assert!(
            mine.iter()
                .all(|(at, m)| ((*at - m.time).as_secs_f64() - lag_s).abs() < 1e-9 && m.invalid().is_none())
        );
        let d: Vec<f64> = mine.iter().filter_map(|(_, m)| m.distance_m).collect();
        assert_eq!(d.len(), mine.len(), "{orientation:?}: every sample in range");
        let mean = d.iter().sum::<f64>() / d.len() as f64;
        // The bottom one's noise is clipped at its minimum, so its mean sits a little above.
        assert!((mean - reads_m).abs() < 0.01, "{orientation:?}: mean {mean}");
        if orientation == RangefinderOrientation::Up {
            within_5_percent("rangefinder noise", std_dev(d), 0.01);
        }
    }
}

#[test]
fn the_same_seed_gives_the_same_run_and_another_seed_does_not() {
    let (_, a) = record(2.0, 7);
    let (_, b) = record(2.0, 7);
    let (_, c) = record(2.0, 8);
    assert_eq!(a, b);
    assert_ne!(a, c);
}

#[test]
fn the_magnetometer_sees_the_field_turn_with_the_body() {
    let body = kestrel_sim::RigidBodyState {
        attitude: nalgebra::UnitQuaternion::from_euler_angles(0.0, 0.0, std::f64::consts::FRAC_PI_2),
        ..Default::default()
    };
    let mut vehicle = VehicleParams::default();
    vehicle.sensors.mag.noise_gauss = 0.0;
    vehicle.sensors.mag.hard_iron_gauss = [0.01, 0.0, 0.0];
    let options = SimOptions {
        initial: kestrel_sim::InitialState { body, ..Default::default() },
        ..SimOptions::default()
    };
    let mut sim = Simulator::new(vehicle, World::default(), options).expect("valid");
    sim.advance_to(Time::from_secs_f64(0.1));
    let sample = sim.drain().find_map(|o| if let SimOutput::Mag(m) = o { Some(m) } else { None }).unwrap();
    let field = World::default().magnetic_field.ned_gauss();
    // Facing east, the body's right axis points south and its forward axis east.
    assert!((sample.field_gauss[0] - (field.y + 0.01)).abs() < 1e-12, "{sample:?}");
    assert!((sample.field_gauss[1] + field.x).abs() < 1e-12, "{sample:?}");
    assert!((sample.field_gauss[2] - field.z).abs() < 1e-12, "{sample:?}");
}

#[test]
fn board_rotation_soft_iron_and_accel_errors_follow_their_documented_models() {
    // measured_accel = scale ⊙ (R_boardᵀ · f_airframe) + offset; measured_mag = soft_iron ·
    // (R_boardᵀ · B_airframe) + hard_iron; gyro = R_boardᵀ · ω; here without noise or bias walk.
    let attitude = nalgebra::UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1);
    let body = kestrel_sim::RigidBodyState { attitude, ..Default::default() };
    let mut vehicle = VehicleParams::default();
    vehicle.sensors.board_rotation_deg = [3.0, -2.0, 10.0];
    let imu = &mut vehicle.sensors.imu;
    (imu.gyro_noise_rad_s, imu.accel_noise_m_s2) = (0.0, 0.0);
    (imu.gyro_bias_walk_rad_s_per_sqrt_s, imu.accel_bias_walk_m_s2_per_sqrt_s) = (0.0, 0.0);
    imu.gyro_bias_initial_rad_s = [0.01, 0.02, 0.03];
    imu.accel_offset_m_s2 = [0.3, -0.3, 0.3];
    imu.accel_scale = [1.02, 0.98, 1.02];
    let mag = &mut vehicle.sensors.mag;
    mag.noise_gauss = 0.0;
    mag.hard_iron_gauss = [0.15, -0.1, 0.2];
    // Not symmetric, so a transposed matrix would show.
    mag.soft_iron = [[1.1, 0.05, -0.05], [0.02, 0.9, 0.05], [-0.03, 0.08, 1.05]];
    let options = SimOptions {
        initial: kestrel_sim::InitialState { body, ..Default::default() },
        ..SimOptions::default()
    };
    let mut sim = Simulator::new(vehicle.clone(), World::default(), options).expect("valid");
    sim.advance_to(Time::from_secs_f64(0.1));
    let outputs: Vec<SimOutput> = sim.drain().collect();
    let imu =
        outputs.iter().rev().find_map(|o| if let SimOutput::Imu(m) = o { Some(m) } else { None }).unwrap();
    let mag =
        outputs.iter().rev().find_map(|o| if let SimOutput::Mag(m) = o { Some(m) } else { None }).unwrap();

    let [r, p, y] = [3.0f64, -2.0, 10.0].map(f64::to_radians);
    let board = nalgebra::Rotation3::from_euler_angles(r, p, y);
    let g = kestrel_proto::units::GRAVITY_M_S2;
    // Resting on the ground: specific force 1 g up, no rotation.
    let force_board = board.transpose() * (attitude.inverse() * nalgebra::Vector3::new(0.0, 0.0, -g));
    let expected_accel = force_board.component_mul(&nalgebra::Vector3::new(1.02, 0.98, 1.02))
        + nalgebra::Vector3::new(0.3, -0.3, 0.3);
    let field_board = board.transpose() * (attitude.inverse() * World::default().magnetic_field.ned_gauss());
    let soft = nalgebra::Matrix3::new(1.1, 0.05, -0.05, 0.02, 0.9, 0.05, -0.03, 0.08, 1.05);
    let expected_mag = soft * field_board + nalgebra::Vector3::new(0.15, -0.1, 0.2);
    for i in 0..3 {
        assert!((imu.accel_m_s2[i] - expected_accel[i]).abs() < 1e-9, "{imu:?} vs {expected_accel}");
        assert!((mag.field_gauss[i] - expected_mag[i]).abs() < 1e-12, "{mag:?} vs {expected_mag}");
        assert!((imu.gyro_rad_s[i] - [0.01, 0.02, 0.03][i]).abs() < 1e-12, "{imu:?}");
    }
    // Level and aligned, the same vehicle without the board rotation reads exactly −g·scale + offset.
    vehicle.sensors.board_rotation_deg = [0.0; 3];
    let mut sim = Simulator::new(vehicle, World::default(), SimOptions::default()).expect("valid");
    sim.advance_to(Time::from_secs_f64(0.01));
    let imu = sim.drain().find_map(|o| if let SimOutput::Imu(m) = o { Some(m) } else { None }).unwrap();
    assert!((imu.accel_m_s2[2] - (-g * 1.02 + 0.3)).abs() < 1e-9, "{imu:?}");
    assert!((imu.accel_m_s2[0] - 0.3).abs() < 1e-9, "{imu:?}");
}
