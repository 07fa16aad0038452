//! Closed-loop flights on the simulator: accuracy against ground truth, lag compensation,
//! faults, and the alignment on the ground and in flight. Run
//! with `--nocapture` to see the figures.
//!
//! The alignment tests use the thesis's sensor noise: a magnetometer at 0.05 gauss per axis
//! against a 0.41 gauss field (about 7° of heading noise per sample) and a barometer at 2 m.

mod common;

use common::{
    Faults, GROUND_S, SETTLE_S, fly, fly_with_sensors, gps_lead_s, nees_test, params, rms, thesis_params,
    thesis_sensors,
};
use kestrel_estimator::EkfParams;

const FLIGHT_S: f64 = 300.0;
/// Independent runs (seeds) whose time-averaged NEES is tested together: one 5-minute run holds
/// only a few dozen independent NEES samples.
const NEES_RUNS: u64 = 4;

/// The 5-minute flight with the thesis's noise in the simulated sensors (see
/// [`common::thesis_sensors`]) and lags (GPS 220 ms, barometer 50 ms), in wind.
#[test]
fn five_minute_flight_meets_the_accuracy_targets_and_leads_gps_by_the_lag() {
    let p = thesis_params();
    let sensors = thesis_sensors(&p);
    let log = fly_with_sensors(p.clone(), sensors.clone(), FLIGHT_S, Faults::default(), 1);
    let r = rms(&log.samples, SETTLE_S, FLIGHT_S);
    let (extent, climb, yaw_span) = common::flown(&log.samples);
    println!("flown: {extent:.1} m across, {climb:.1} m of height change, {yaw_span:.0}° of yaw");
    assert!(extent > 30.0 && climb > 6.0 && yaw_span > 90.0, "the vehicle did not fly the figure");
    let lead = gps_lead_s(&log, SETTLE_S);
    println!("lag compensation on: {r:?}; estimate leads GPS by {:.1} ms", lead * 1e3);
    println!(
        "barometric datum {:.2} m above home; height RMS against home {:.2} m",
        log.baro_datum_m.unwrap_or(f64::NAN),
        r.vertical_vs_home_m
    );
    println!("status: {:?}; dropped on arrival: {:?}", log.ekf.status(), log.ekf.dropped_samples());
    // Only samples measured before the filter aligned lie behind its horizon.
    let dropped = log.ekf.dropped_samples();
    assert!(dropped.gps <= 2 && dropped.baro <= 3 && dropped.mag <= 25, "{dropped:?}");
    assert!(r.horizontal_m < 0.5, "{r:?}");
    assert!(r.vertical_m < 0.5, "{r:?}");
    assert!(r.velocity_m_s < 0.15, "{r:?}");
    assert!(r.roll_deg < 1.0 && r.pitch_deg < 1.0, "{r:?}");
    assert!(r.yaw_deg < 3.0, "{r:?}");
    assert!((lead - 0.22).abs() <= 0.010, "lead {lead}");

    // NEES of attitude, velocity and position (9 dof) at the delayed horizon, time-averaged
    // over this run and further seeds.
    let others: Vec<_> = (2..=NEES_RUNS)
        .map(|seed| fly_with_sensors(p.clone(), sensors.clone(), FLIGHT_S, Faults::default(), seed))
        .collect();
    for (seed, l) in std::iter::once(&log).chain(&others).enumerate() {
        let t = nees_test(&[l], SETTLE_S);
        println!(
            "seed {}: average NEES {:.2}, 95 % bounds {:.2}..{:.2} (N_eff {:.0})",
            seed + 1,
            t.mean,
            t.bounds.0,
            t.bounds.1,
            t.effective
        );
    }
    let runs: Vec<_> = std::iter::once(&log).chain(&others).collect();
    let t = nees_test(&runs, SETTLE_S);
    let [att, vel, hor, ver] = t.blocks;
    println!(
        "average NEES (attitude, velocity, position; {} dof) {:.2} over {} runs, {} samples, \
         N_eff {:.0} (correlation time {:.1} s); 95 % bounds {:.2}..{:.2}; \
         blocks: attitude {att:.2}/3, velocity {vel:.2}/3, horizontal {hor:.2}/2, vertical {ver:.2}/1",
        common::NEES_DOF,
        t.mean,
        runs.len(),
        t.samples,
        t.effective,
        t.correlation_s,
        t.bounds.0,
        t.bounds.1
    );
    assert!(t.passes(), "{t:?}");

    let off =
        fly_with_sensors(EkfParams { lag_compensation: false, ..p }, sensors, FLIGHT_S, Faults::default(), 1);
    let r_off = rms(&off.samples, SETTLE_S, FLIGHT_S);
    println!("lag compensation off: {r_off:?}");
    assert!(r_off.horizontal_m > 1.5 * r.horizontal_m, "{r_off:?} vs {r:?}");
    assert!(r_off.velocity_m_s > 1.5 * r.velocity_m_s, "{r_off:?} vs {r:?}");
}

#[test]
fn gps_jump_is_rejected_then_loss_is_flagged_and_recovered() {
    let faults = Faults { gps_jump: Some((40.0, 43.0)), gps_loss: Some((60.0, 90.0)), ..Faults::default() };
    let log = fly(params(), 100.0, faults, 2);
    let horizontal_error =
        |s: &common::Sample| (s.est_pos_home_m - nalgebra::Vector3::from(s.truth.position_ned_m)).xy().norm();
    let jump_max = log
        .samples
        .iter()
        .filter(|s| s.tau >= 39.0 && s.tau < 48.0)
        .map(horizontal_error)
        .fold(0.0, f64::max);
    println!("GPS jump: largest horizontal error {jump_max:.2} m; status {:?}", log.ekf.status().gps);
    assert!(jump_max < 1.0, "estimate followed the jump: {jump_max} m");
    assert!(log.ekf.status().gps.rejected >= 10, "{:?}", log.ekf.status().gps);

    let at = |tau: f64| log.samples.iter().find(|s| s.tau >= tau).expect("flight long enough");
    assert!(at(59.0).nav.valid.horizontal_position);
    assert!(!at(70.0).nav.valid.horizontal_position, "loss not flagged");
    let drift = horizontal_error(at(89.0));
    let recovered = log
        .samples
        .iter()
        .find(|s| s.tau >= 90.0 && s.nav.valid.horizontal_position && horizontal_error(s) < 1.0);
    let recovered_after = recovered.map(|s| s.tau - 90.0);
    println!("GPS loss: drift after 30 s {drift:.1} m, recovered {recovered_after:?} s after GPS returned");
    assert!(recovered_after.is_some_and(|t| t < 5.0), "{recovered_after:?}");
}

/// The same 30 s GPS loss flown with the vehicle's drag model: the wind learnt before the loss
/// and the drag the accelerometer reads keep the velocity measured (reported valid, and closer
/// to the truth) and the position drifting far less than on the IMU alone (the same flight
/// without the model).
#[test]
fn with_drag_a_gps_loss_keeps_the_velocity_measured_and_the_drift_small() {
    let faults = Faults { gps_loss: Some((60.0, 90.0)), ..Faults::default() };
    let with = fly(common::params_with_drag(), 92.0, faults, 2);
    let without = fly(params(), 92.0, faults, 2);
    let horizontal_error =
        |s: &common::Sample| (s.est_pos_home_m - nalgebra::Vector3::from(s.truth.position_ned_m)).xy().norm();
    fn at(log: &common::FlightLog, tau: f64) -> &common::Sample {
        log.samples.iter().find(|s| s.tau >= tau).expect("flight long enough")
    }
    let status = with.ekf.status();
    let wind = status.wind_ne_m_s.expect("wind learnt before the loss");
    println!("wind learnt {wind:?} (steady 2.0, 1.5 with 0.8 m/s gusts); drag {:?}", status.drag);
    let velocity_error = |s: &common::Sample| {
        (nalgebra::Vector3::from(s.nav.velocity_ned_m_s) - nalgebra::Vector3::from(s.truth.velocity_ned_m_s))
            .xy()
            .norm()
    };
    let during = |log: &common::FlightLog| -> Vec<common::Sample> {
        log.samples.iter().filter(|s| s.tau >= 61.0 && s.tau < 90.0).cloned().collect()
    };
    let rms = |samples: &[common::Sample]| {
        (samples.iter().map(|s| velocity_error(s).powi(2)).sum::<f64>() / samples.len() as f64).sqrt()
    };
    let (lost, lost_alone) = (during(&with), during(&without));
    let (rms, rms_alone) = (rms(&lost), rms(&lost_alone));
    let (drift, drift_alone) = (horizontal_error(at(&with, 89.0)), horizontal_error(at(&without, 89.0)));
    println!(
        "GPS lost 30 s with drag: velocity error RMS {rms:.2} m/s, drift {drift:.1} m; IMU alone: {rms_alone:.2} \
         m/s, {drift_alone:.1} m"
    );
    assert!(
        lost.iter().all(|s| s.nav.valid.horizontal_velocity),
        "velocity reported invalid during the loss"
    );
    assert!(!at(&with, 70.0).nav.valid.horizontal_position, "position is still not measured");
    assert!(!at(&without, 70.0).nav.valid.horizontal_velocity, "without drag the velocity is not measured");
    assert!(status.drag.fused > 250, "{:?}", status.drag);
    // The gusts (0.8 m/s per axis) are air the drag cannot tell from the vehicle's own motion:
    // most of what is left is them.
    assert!(rms < 0.5 * rms_alone, "velocity error RMS {rms} m/s, IMU alone {rms_alone} m/s");
    assert!(drift < 0.5 * drift_alone, "drift {drift} m, IMU alone {drift_alone} m");
}

#[test]
fn magnetometer_disturbance_does_not_flip_yaw() {
    let faults = Faults { mag_disturbance: Some((30.0, 45.0)), ..Faults::default() };
    let log = fly(params(), 60.0, faults, 3);
    let worst_yaw = log
        .samples
        .iter()
        .filter(|s| s.tau >= SETTLE_S)
        .map(|s| common::euler_errors(&s.nav.attitude, &s.truth.attitude)[2].abs().to_degrees())
        .fold(0.0, f64::max);
    println!("mag disturbance: worst yaw error {worst_yaw:.2}°, status {:?}", log.ekf.status().mag);
    assert!(worst_yaw < 5.0, "{worst_yaw}");
    assert!(log.ekf.status().mag.rejected > 100);
}

/// Seeds of the alignment figures.
const ALIGNMENT_SEEDS: u64 = 8;

fn yaw_error_deg(s: &common::Sample) -> f64 {
    common::euler_errors(&s.nav.attitude, &s.truth.attitude)[2].to_degrees()
}

fn rms_of(values: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = values.fold((0.0, 0.0), |(s, n), v| (s + v * v, n + 1.0));
    (sum / n).sqrt()
}

/// Yaw and height datum come from averages over the still window, so their error is the
/// sensors' noise over √N, not one sample's: over 8 seeds the yaw error just after alignment
/// and the datum's error against the simulator's home stay well below one sample's noise (7°,
/// 2 m), and the magnetometer, measured against an averaged reference field, is rarely
/// rejected in flight (with one sample's field, a quarter of all samples were).
#[test]
fn alignment_references_are_averages_over_the_still_window() {
    let p = thesis_params();
    let sensors = thesis_sensors(&p);
    let mut yaw = Vec::new();
    let mut datum = Vec::new();
    let mut rejected = 0;
    let mut fused = 0;
    for seed in 1..=ALIGNMENT_SEEDS {
        let log = fly_with_sensors(p.clone(), sensors.clone(), 30.0, Faults::default(), seed);
        let first = log.samples.first().expect("aligned on the ground");
        assert!(first.tau < -0.5, "aligned at {} s, not on the ground", first.tau + GROUND_S);
        yaw.push(yaw_error_deg(first));
        datum.push(log.baro_datum_m.expect("barometer during alignment"));
        let mag = log.ekf.status().mag;
        rejected += mag.rejected;
        fused += mag.fused;
    }
    let yaw_rms = rms_of(yaw.iter().copied());
    let datum_rms = rms_of(datum.iter().copied());
    println!(
        "initial yaw error over {ALIGNMENT_SEEDS} seeds: RMS {yaw_rms:.2}°, each {yaw:.2?}; height datum error RMS \
         {datum_rms:.3} m, each {datum:.3?}; magnetometer over {ALIGNMENT_SEEDS} × 33 s: {rejected} rejected, \
         {fused} fused"
    );
    assert!(yaw_rms < 2.0, "{yaw:?}");
    // The datum's error also holds the simulated barometer's fixed offset at home (≈ 0.5 m
    // here), which no averaging removes; one sample's 2 m noise would dominate it.
    assert!(datum_rms < 1.0, "{datum:?}");
    assert!((rejected as f64) < 0.05 * fused as f64, "{rejected} rejected, {fused} fused");
}

/// A fixed field of 0.25 gauss east near the ground (steel under the pad) turns the aligned
/// heading by ≈ 31° and, fused on the ground, leaves a confident wrong yaw. Above 1.5 m the
/// filter realigns yaw and the reference field from the magnetometer once, and the yaw error
/// after the climb falls below the 3° bound of the undisturbed flight. Without the realignment
/// the gate rejects the clean field and the error stays.
#[test]
fn in_flight_yaw_realignment_clears_a_ground_disturbance() {
    let p = thesis_params();
    let sensors = thesis_sensors(&p);
    let faults = Faults { ground_mag_disturbance: Some([0.0, 0.25, 0.0]), ..Faults::default() };
    let run = |params: EkfParams| {
        let log = fly_with_sensors(params, sensors.clone(), 40.0, faults, 5);
        let on_ground = yaw_error_deg(log.samples.iter().find(|s| s.tau >= -0.1).expect("aligned"));
        let after_climb = rms_of(log.samples.iter().filter(|s| s.tau >= 10.0).map(yaw_error_deg));
        (on_ground, after_climb, log.ekf.status().mag)
    };
    let (ground, with, mag) = run(p.clone());
    println!(
        "with realignment: yaw error on the ground {ground:.1}°, after the climb RMS {with:.2}°; {mag:?}"
    );
    let (ground_off, without, mag_off) = run(EkfParams { in_flight_yaw_reset: false, ..p });
    println!(
        "without: yaw error on the ground {ground_off:.1}°, after the climb RMS {without:.2}°; {mag_off:?}"
    );
    assert!(ground.abs() > 15.0, "the disturbance did not turn the aligned yaw: {ground}");
    assert_eq!(mag.resets, 1);
    assert!(with < 3.0, "{with}");
    assert!(without > 2.0 * with, "{without} vs {with}");
}
