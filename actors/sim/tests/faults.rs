//! Each fault kind's effect on the simulator's output, against an independent expectation: the
//! same run (same seed) without the fault, plus what the fault should add. Sensor noise is
//! drawn whatever the faults, so outside a fault's window the two runs agree exactly.

use kestrel_proto::Time;
use kestrel_proto::geo::{Geodetic, LocalFrame};
use kestrel_proto::messages::{
    ActuatorOutputs, BaroSample, BatteryStatus, EscTelemetry, GpsFix, GpsFixType, GroundTruth, ImuSample,
    MAX_MOTORS, MagSample, SimFault, SimFaultPhase,
};
use kestrel_sim::sensors::gps::NO_FIX_ACCURACY;
use kestrel_sim::{
    Fault, FaultKind, InitialState, RigidBodyState, SimOptions, SimOutput, Simulator, VehicleParams, World,
    hover_throttle,
};

/// Everything released over `seconds`, hovering open loop at `height_m` (0: resting on the
/// ground, disarmed) in `world` with `faults`.
fn run(vehicle: &VehicleParams, faults: &[Fault], height_m: f64, seconds: f64) -> Vec<SimOutput> {
    let world = World { faults: faults.to_vec(), ..World::default() };
    let mut actuators = ActuatorOutputs::default();
    if height_m > 0.0 {
        actuators.armed = true;
        actuators.motors = [hover_throttle(vehicle); MAX_MOTORS];
    }
    let body = RigidBodyState { position_ned_m: [0.0, 0.0, -height_m].into(), ..RigidBodyState::default() };
    let options = SimOptions { seed: 7, initial: InitialState { body, actuators }, ..SimOptions::default() };
    let mut sim = Simulator::new(vehicle.clone(), world, options).expect("valid");
    sim.advance_to(Time::from_secs_f64(seconds));
    sim.drain().collect()
}

fn fault(at_s: f64, for_s: Option<f64>, kind: FaultKind) -> Fault {
    Fault { at_s, for_s, kind }
}

fn gps(out: &[SimOutput]) -> Vec<GpsFix> {
    out.iter().filter_map(|o| if let SimOutput::Gps(m) = o { Some(m.clone()) } else { None }).collect()
}
fn imu(out: &[SimOutput]) -> Vec<ImuSample> {
    out.iter().filter_map(|o| if let SimOutput::Imu(m) = o { Some(m.clone()) } else { None }).collect()
}
fn mag(out: &[SimOutput]) -> Vec<MagSample> {
    out.iter().filter_map(|o| if let SimOutput::Mag(m) = o { Some(m.clone()) } else { None }).collect()
}
fn baro(out: &[SimOutput]) -> Vec<BaroSample> {
    out.iter().filter_map(|o| if let SimOutput::Baro(m) = o { Some(m.clone()) } else { None }).collect()
}
fn battery(out: &[SimOutput]) -> Vec<BatteryStatus> {
    out.iter().filter_map(|o| if let SimOutput::Battery(m) = o { Some(m.clone()) } else { None }).collect()
}
fn esc(out: &[SimOutput]) -> Vec<EscTelemetry> {
    out.iter().filter_map(|o| if let SimOutput::Esc(m) = o { Some(m.clone()) } else { None }).collect()
}
fn truth(out: &[SimOutput]) -> Vec<GroundTruth> {
    out.iter()
        .filter_map(|o| if let SimOutput::GroundTruth(m) = o { Some(m.clone()) } else { None })
        .collect()
}
fn events(out: &[SimOutput]) -> Vec<SimFault> {
    out.iter().filter_map(|o| if let SimOutput::Fault(m) = o { Some(m.clone()) } else { None }).collect()
}

fn within(t: Time, from_s: f64, to_s: f64) -> bool {
    Time::from_secs_f64(from_s) <= t && t < Time::from_secs_f64(to_s)
}

fn ned(fix: &GpsFix) -> [f64; 3] {
    LocalFrame::new(World::default().home.geodetic()).to_ned(Geodetic {
        lat_deg: fix.lat_deg,
        lon_deg: fix.lon_deg,
        alt_m: fix.alt_msl_m,
    })
}

#[test]
fn gps_jump_shifts_the_reported_position_by_exactly_ned_m_in_its_window() {
    let v = VehicleParams::default();
    let base = gps(&run(&v, &[], 0.0, 20.0));
    let jumped =
        gps(&run(&v, &[fault(5.0, Some(5.0), FaultKind::GpsJump { ned_m: [50.0, -20.0, 3.0] })], 0.0, 20.0));
    assert_eq!(base.len(), jumped.len());
    let mut shifted = 0;
    for (b, j) in base.iter().zip(&jumped) {
        assert_eq!(b.time, j.time);
        let (pb, pj) = (ned(b), ned(j));
        let d = [pj[0] - pb[0], pj[1] - pb[1], pj[2] - pb[2]];
        if within(b.time, 5.0, 10.0) {
            shifted += 1;
            for (got, want) in d.iter().zip([50.0, -20.0, 3.0]) {
                assert!((got - want).abs() < 1e-6, "{:?} at {}", d, b.time);
            }
            assert_eq!(b.vel_ned_m_s, j.vel_ned_m_s, "velocity unchanged");
        } else {
            assert_eq!(b, j, "outside the window the fix is untouched");
        }
    }
    assert_eq!(shifted, 25, "5 s of 5 Hz fixes");
}

#[test]
fn gps_off_keeps_the_rate_but_reports_no_fix_and_holds_the_last_position() {
    let v = VehicleParams::default();
    let base = gps(&run(&v, &[], 0.0, 20.0));
    let off = gps(&run(&v, &[fault(5.0, Some(5.0), FaultKind::GpsOff)], 0.0, 20.0));
    assert_eq!(base.len(), off.len(), "a u-blox keeps sending at its rate");
    let last_good = off.iter().rfind(|f| f.time < Time::from_secs_f64(5.0)).expect("a fix before").clone();
    for (b, o) in base.iter().zip(&off) {
        if within(b.time, 5.0, 10.0) {
            assert_eq!(o.fix_type, GpsFixType::NoFix);
            assert_eq!((o.satellites, o.vel_ned_m_s, o.h_acc_m), (0, [0.0; 3], NO_FIX_ACCURACY));
            assert_eq!(
                (o.lat_deg, o.lon_deg, o.alt_msl_m),
                (last_good.lat_deg, last_good.lon_deg, last_good.alt_msl_m)
            );
        } else {
            assert_eq!(b, o);
        }
    }
}

#[test]
fn gps_noise_multiplies_the_position_error_by_its_factor() {
    // At rest at home the reported position is the noise itself.
    let v = VehicleParams::default();
    let base = gps(&run(&v, &[], 0.0, 10.0));
    let noisy = gps(&run(&v, &[fault(0.0, None, FaultKind::GpsNoise { factor: 3.0 })], 0.0, 10.0));
    for (b, n) in base.iter().zip(&noisy) {
        let (pb, pn) = (ned(b), ned(n));
        for axis in 0..3 {
            assert!((pn[axis] - 3.0 * pb[axis]).abs() < 1e-6, "{pn:?} vs 3 × {pb:?}");
            assert!((n.vel_ned_m_s[axis] - 3.0 * b.vel_ned_m_s[axis]).abs() < 1e-12);
        }
        assert_eq!(n.h_acc_m, b.h_acc_m, "the receiver does not know");
    }
}

#[test]
fn mag_anomaly_adds_its_field_and_mag_stuck_repeats_the_last_reading() {
    let v = VehicleParams::default();
    let base = mag(&run(&v, &[], 0.0, 6.0));
    let faulted = mag(&run(
        &v,
        &[
            fault(1.0, Some(1.0), FaultKind::MagAnomaly { gauss: [0.3, -0.1, 0.05] }),
            fault(3.0, Some(1.0), FaultKind::MagStuck),
        ],
        0.0,
        6.0,
    ));
    assert_eq!(base.len(), faulted.len());
    let before_stuck = faulted.iter().rfind(|m| m.time < Time::from_secs_f64(3.0)).expect("before").clone();
    for (b, f) in base.iter().zip(&faulted) {
        assert_eq!(b.time, f.time, "fresh stamps");
        if within(b.time, 1.0, 2.0) {
            for (axis, added) in [0.3, -0.1, 0.05].iter().enumerate() {
                assert!((f.field_gauss[axis] - b.field_gauss[axis] - added).abs() < 1e-12);
            }
        } else if within(b.time, 3.0, 4.0) {
            assert_eq!(f.field_gauss, before_stuck.field_gauss);
        } else {
            assert_eq!(b, f);
        }
    }
}

#[test]
fn baro_drift_reaches_ten_times_m_s_after_ten_seconds_and_baro_stuck_repeats() {
    let v = VehicleParams::default();
    let base = baro(&run(&v, &[], 0.0, 30.0));
    let faulted = baro(&run(
        &v,
        &[
            fault(2.0, Some(12.0), FaultKind::BaroDrift { m_s: 0.5 }),
            fault(20.0, Some(5.0), FaultKind::BaroStuck),
        ],
        0.0,
        30.0,
    ));
    let at = |samples: &[BaroSample], s: f64| {
        samples.iter().find(|m| m.time == Time::from_secs_f64(s)).expect("a sample at that time").clone()
    };
    let error_at = |s| at(&faulted, s).altitude_m - at(&base, s).altitude_m;
    assert!((error_at(12.0) - 10.0 * 0.5).abs() < 1e-3, "{} m after 10 s", error_at(12.0));
    assert!((error_at(7.0) - 5.0 * 0.5).abs() < 1e-3, "{} m after 5 s", error_at(7.0));
    assert_eq!(error_at(1.0), 0.0);
    assert_eq!(error_at(14.0), 0.0, "gone at the end");
    let before_stuck = at(&faulted, 19.9);
    for m in faulted.iter().filter(|m| within(m.time, 20.0, 25.0)) {
        assert_eq!((m.pressure_pa, m.altitude_m), (before_stuck.pressure_pa, before_stuck.altitude_m));
    }
    assert_eq!(at(&faulted, 26.0), at(&base, 26.0));
}

#[test]
fn imu_bias_steps_add_exactly_their_values() {
    let v = VehicleParams::default();
    let base = imu(&run(&v, &[], 0.0, 3.0));
    let faulted = imu(&run(
        &v,
        &[
            fault(1.0, Some(1.0), FaultKind::GyroBias { rad_s: [0.0873, 0.0, -0.01] }),
            fault(1.5, None, FaultKind::AccelBias { m_s2: [0.5, 0.0, 0.0] }),
        ],
        0.0,
        3.0,
    ));
    assert_eq!(base.len(), faulted.len());
    for (b, f) in base.iter().zip(&faulted) {
        let gyro = if within(b.time, 1.0, 2.0) { [0.0873, 0.0, -0.01] } else { [0.0; 3] };
        let accel = if within(b.time, 1.5, 1e9) { [0.5, 0.0, 0.0] } else { [0.0; 3] };
        for axis in 0..3 {
            assert!((f.gyro_rad_s[axis] - b.gyro_rad_s[axis] - gyro[axis]).abs() < 1e-12, "{}", b.time);
            assert!((f.accel_m_s2[axis] - b.accel_m_s2[axis] - accel[axis]).abs() < 1e-12, "{}", b.time);
        }
    }
}

#[test]
fn accel_clip_clamps_at_the_full_scale_range_and_flags_the_axis() {
    // A ±0.5 g range, so that resting on the ground (−1 g on z) clips.
    let mut v = VehicleParams::default();
    v.sensors.imu.accel_full_scale_g = 0.5;
    let range_m_s2 = 0.5 * kestrel_proto::units::GRAVITY_M_S2;
    let base = imu(&run(&v, &[], 0.0, 2.0));
    let clipped = imu(&run(&v, &[fault(1.0, None, FaultKind::AccelClip)], 0.0, 2.0));
    let mut n = 0;
    for (b, c) in base.iter().zip(&clipped) {
        if b.time < Time::from_secs_f64(1.0) {
            assert_eq!(b, c);
            assert!(b.accel_m_s2[2] < -9.0, "the healthy IMU reads −1 g");
            continue;
        }
        n += 1;
        assert_eq!(c.accel_m_s2[2], -range_m_s2);
        assert_eq!(c.accel_clipped, [false, false, true]);
        assert_eq!(c.accel_m_s2[..2], b.accel_m_s2[..2], "small axes pass through");
    }
    assert_eq!(n, 401, "ticks 1.0 s to 2.0 s inclusive");
    // With the default ±16 g, resting never clips.
    let default = imu(&run(&VehicleParams::default(), &[fault(0.0, None, FaultKind::AccelClip)], 0.0, 1.0));
    assert!(default.iter().all(|s| s.accel_clipped == [false; 3]));
}

#[test]
fn imu_stop_publishes_no_sample_in_its_window_while_the_clock_and_other_sensors_run_on() {
    let v = VehicleParams::default();
    let out = run(&v, &[fault(1.0, Some(2.0), FaultKind::ImuStop)], 0.0, 4.0);
    let samples = imu(&out);
    assert!(samples.iter().all(|s| !within(s.time, 1.0, 3.0)), "a sample in the stop window");
    assert_eq!(samples.len(), 400 * 2, "1 s before and 1 s after");
    assert_eq!(samples.first().map(|s| s.time), Some(Time::from_micros(2500)));
    assert_eq!(
        samples.iter().find(|s| s.time >= Time::from_secs_f64(1.0)).map(|s| s.time),
        Some(Time::from_secs_f64(3.0))
    );
    assert!(mag(&out).iter().filter(|m| within(m.time, 1.0, 3.0)).count() >= 199);
    assert!(truth(&out).iter().filter(|t| within(t.time, 1.0, 3.0)).count() == 100);
}

#[test]
fn a_lost_motor_takes_a_quarter_of_the_thrust_and_a_weak_one_its_share() {
    // In hover, losing thrust k of one motor of four accelerates the vehicle down at (1 − k)/4 g
    // at once (before it tilts or gains speed).
    let v = VehicleParams::default();
    for (kind, lost_share) in
        [(FaultKind::MotorLost { motor: 1 }, 0.25), (FaultKind::MotorWeak { motor: 1, thrust: 0.5 }, 0.125)]
    {
        let out = run(&v, &[fault(1.0, None, kind.clone())], 10.0, 1.1);
        let truths = truth(&out);
        let before = truths.iter().find(|t| t.time == Time::from_secs_f64(0.98)).expect("before");
        let after = truths.iter().find(|t| t.time == Time::from_secs_f64(1.02)).expect("after");
        assert!(before.acceleration_ned_m_s2[2].abs() < 1e-6, "{:?}", before.acceleration_ned_m_s2);
        let expected = lost_share * kestrel_proto::units::GRAVITY_M_S2;
        assert!(
            (after.acceleration_ned_m_s2[2] - expected).abs() < 0.01 * expected,
            "{kind:?}: {:?}",
            after.acceleration_ned_m_s2
        );
        // It also rolls and pitches away from the failed motor (1 is front right on a quad-X).
        assert!(after.angular_velocity_rad_s[0].abs() > 0.0 && after.angular_velocity_rad_s[1].abs() > 0.0);
        // The ESCs report what the motors produce: the hover command before, and after it the
        // fault's share on motor 1 (hover speed is unchanged within 20 ms of open loop).
        let escs = esc(&out);
        let at = |t: f64| escs.iter().find(|e| e.time == Time::from_secs_f64(t)).expect("esc");
        let hover = hover_throttle(&v);
        assert_eq!(at(0.98).count, 4);
        assert!(at(0.98).thrust[..4].iter().all(|t| (t - hover).abs() < 1e-9), "{:?}", at(0.98));
        let kept = 1.0 - 4.0 * lost_share;
        assert!((at(1.02).thrust[0] - kept * hover).abs() < 1e-9, "{kind:?}: {:?}", at(1.02));
        assert!(at(1.02).thrust[1..4].iter().all(|t| (t - hover).abs() < 1e-9), "{:?}", at(1.02));
        assert!(at(1.02).thrust[4..].iter().all(|&t| t == 0.0));
    }
}

#[test]
fn battery_sag_lowers_the_reported_voltage_by_exactly_its_volts() {
    let v = VehicleParams::default();
    let base = battery(&run(&v, &[], 10.0, 4.0));
    let sagged = battery(&run(&v, &[fault(1.0, Some(2.0), FaultKind::BatterySag { volts: 1.2 })], 10.0, 4.0));
    for (b, s) in base.iter().zip(&sagged) {
        let sag = if within(b.time, 1.0, 3.0) { 1.2 } else { 0.0 };
        assert!(
            (b.voltage_v - s.voltage_v - sag).abs() < 1e-12,
            "{} vs {} at {}",
            b.voltage_v,
            s.voltage_v,
            b.time
        );
        assert_eq!((b.current_a, b.consumed_mah), (s.current_a, s.consumed_mah));
    }
}

#[test]
fn a_wind_fault_flies_like_a_world_with_that_wind_and_ends_back_in_still_air() {
    let v = VehicleParams::default();
    let gale = FaultKind::Wind { ned_m_s: [6.0, -2.0, 0.0], gust_m_s: 0.0 };
    let faulted = truth(&run(&v, &[fault(0.0, Some(5.0), gale)], 10.0, 8.0));
    let world = World {
        wind: kestrel_sim::WindParams { steady_ned_m_s: [6.0, -2.0, 0.0], ..Default::default() },
        ..World::default()
    };
    let mut actuators = ActuatorOutputs { armed: true, ..ActuatorOutputs::default() };
    actuators.motors = [hover_throttle(&v); MAX_MOTORS];
    let body = RigidBodyState { position_ned_m: [0.0, 0.0, -10.0].into(), ..RigidBodyState::default() };
    let options = SimOptions { seed: 7, initial: InitialState { body, actuators }, ..SimOptions::default() };
    let mut windy = Simulator::new(v.clone(), world, options).expect("valid");
    windy.advance_to(Time::from_secs_f64(8.0));
    let windy = truth(&windy.drain().collect::<Vec<_>>());
    for (f, w) in faulted.iter().zip(&windy).filter(|(f, _)| f.time < Time::from_secs_f64(5.0)) {
        assert_eq!(f.velocity_ned_m_s, w.velocity_ned_m_s, "at {}", f.time);
    }
    let end = |t: &[GroundTruth]| t.last().expect("samples").velocity_ned_m_s;
    let at_5 = faulted.iter().find(|t| t.time == Time::from_secs_f64(5.0)).expect("5 s").velocity_ned_m_s;
    // Blown north-west while it blows; drag then slows the drift in still air, unlike the
    // world where it keeps blowing.
    assert!(at_5[0] > 1.0 && at_5[1] < -0.3, "{at_5:?}");
    assert!(end(&faulted)[0] < at_5[0] && end(&windy)[0] > at_5[0], "{:?} {:?}", end(&faulted), end(&windy));
}

#[test]
fn every_start_and_end_is_released_once_with_its_kind_and_values() {
    let v = VehicleParams::default();
    let out = run(
        &v,
        &[
            fault(1.0, Some(0.5), FaultKind::MotorWeak { motor: 2, thrust: 0.7 }),
            fault(0.0, None, FaultKind::GpsOff),
        ],
        10.0,
        3.0,
    );
    let got: Vec<(u64, u32, SimFaultPhase, String, String)> =
        events(&out).into_iter().map(|e| (e.time.0, e.index, e.phase, e.kind, e.values)).collect();
    let weak = ("motor_weak".to_owned(), "motor = 2, thrust = 0.7".to_owned());
    assert_eq!(
        got,
        [
            (2_500, 1, SimFaultPhase::Started, "gps_off".to_owned(), String::new()),
            (1_000_000, 0, SimFaultPhase::Started, weak.0.clone(), weak.1.clone()),
            (1_500_000, 0, SimFaultPhase::Ended, weak.0, weak.1),
        ]
    );
}

#[test]
fn a_motor_outside_the_frame_is_refused_at_start_and_actor_panic_left_to_the_runtime() {
    let world = |kind| World { faults: vec![fault(1.0, None, kind)], ..World::default() };
    let new = |kind| Simulator::new(VehicleParams::default(), world(kind), SimOptions::default()).err();
    let err = new(FaultKind::MotorLost { motor: 5 }).expect("a quad has four motors");
    assert_eq!(err.field, "faults[0].motor");
    assert!(new(FaultKind::MotorLost { motor: 4 }).is_none());
    assert!(new(FaultKind::ActorPanic { actor: "estimator".into() }).is_none());
}
