//! Closed-loop flights on the simulator: accuracy against ground truth, lag compensation and
//! faults (issue 3's acceptance figures). Run with `--nocapture` to see the figures.

mod common;

use common::{
    Faults, SETTLE_S, fly, fly_with_sensors, gps_lead_s, nees_test, params, rms, thesis_params,
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
    println!("status: {:?}", log.ekf.status());
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
