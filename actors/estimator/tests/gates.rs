//! Each innovation gate rejects a 10σ outlier and leaves the state alone.

use kestrel_estimator::ekf::DroppedSamples;
use kestrel_estimator::{Ekf, EkfParams, InputError};
use kestrel_proto::Time;
use kestrel_proto::geo::{Geodetic, LocalFrame};
use kestrel_proto::messages::{BaroSample, GpsFix, GpsFixType, ImuSample, MagSample};
use kestrel_proto::units::GRAVITY_M_S2;
use nalgebra::{UnitQuaternion, Vector3};

const HOME: Geodetic = Geodetic { lat_deg: 6.7971, lon_deg: 79.9017, alt_m: 20.0 };
const FIELD_NED: [f64; 3] = [0.4, 0.0, -0.03];

/// A still, level vehicle at home with noiseless sensors.
struct Bench {
    ekf: Ekf,
    t_us: u64,
}

/// A 400 Hz sample of a vehicle standing still and level at `time`.
fn still_imu(time: Time) -> ImuSample {
    ImuSample {
        time,
        gyro_rad_s: [0.0; 3],
        accel_m_s2: [0.0, 0.0, -GRAVITY_M_S2],
        dt_s: 0.0025,
        gyro_clipped: [false; 3],
        accel_clipped: [false; 3],
    }
}

impl Bench {
    fn new(params: EkfParams) -> Bench {
        Bench { ekf: Ekf::new(params).unwrap(), t_us: 0 }
    }

    fn gps(&self, ned: [f64; 3]) -> GpsFix {
        let g = LocalFrame::new(HOME).to_geodetic(ned);
        GpsFix {
            time: Time::from_micros(self.t_us),
            fix_type: GpsFixType::Fix3d,
            satellites: 12,
            lat_deg: g.lat_deg,
            lon_deg: g.lon_deg,
            alt_msl_m: g.alt_m,
            vel_ned_m_s: [0.0; 3],
            h_acc_m: 0.5,
            v_acc_m: 0.8,
            s_acc_m_s: 0.1,
        }
    }

    /// Runs the sensor streams for `seconds`.
    fn run(&mut self, seconds: f64) {
        let end = self.t_us + (seconds * 1e6) as u64;
        while self.t_us < end {
            self.t_us += 2500;
            let time = Time::from_micros(self.t_us);
            self.ekf.push_imu(&still_imu(time)).unwrap();
            if self.t_us.is_multiple_of(200_000) {
                let fix = self.gps([0.0; 3]);
                self.ekf.push_gps(&fix).unwrap();
            }
            if self.t_us.is_multiple_of(100_000) {
                let baro = BaroSample { time, pressure_pa: 101_000.0, altitude_m: 20.0, temperature_c: 25.0 };
                self.ekf.push_baro(&baro).unwrap();
            }
            if self.t_us.is_multiple_of(10_000) {
                self.ekf.push_mag(&MagSample { time, field_gauss: FIELD_NED }).unwrap();
            }
        }
    }
}

fn settled(params: EkfParams) -> Bench {
    let mut bench = Bench::new(params);
    bench.run(30.0);
    bench
}

#[test]
fn gps_gate_rejects_a_ten_sigma_position_outlier() {
    let mut bench = settled(EkfParams::default());
    let sigma = bench.ekf.status().gps_position_ne[0].variance.sqrt();
    let before = *bench.ekf.delayed_state().unwrap();
    // Stamped just after the regular fix of the same instant (a repeated stamp is refused).
    let fix = GpsFix { time: Time::from_micros(bench.t_us + 1), ..bench.gps([10.0 * sigma, 0.0, 0.0]) };
    bench.ekf.push_gps(&fix).unwrap();
    bench.run(0.3);
    let status = bench.ekf.status();
    let after = bench.ekf.delayed_state().unwrap();
    assert_eq!(status.gps.rejected, 1, "{status:?}");
    assert!((status.gps_position_ne[0].test_ratio - 4.0).abs() < 0.5, "{status:?}");
    assert!((after.pos_ned_m - before.pos_ned_m).norm() < 0.01);
}

#[test]
fn baro_gate_rejects_a_ten_sigma_height_outlier() {
    let mut bench = settled(EkfParams { fuse_baro_climb_rate: false, ..EkfParams::default() });
    let sigma = bench.ekf.status().baro_height.variance.sqrt();
    let before = *bench.ekf.delayed_state().unwrap();
    let time = Time::from_micros(bench.t_us + 1);
    let outlier =
        BaroSample { time, pressure_pa: 100_000.0, altitude_m: 20.0 + 10.0 * sigma, temperature_c: 25.0 };
    bench.ekf.push_baro(&outlier).unwrap();
    bench.run(0.3);
    let status = bench.ekf.status();
    assert_eq!(status.baro.rejected, 1, "{status:?}");
    assert!((bench.ekf.delayed_state().unwrap().pos_ned_m.z - before.pos_ned_m.z).abs() < 0.01);
}

#[test]
fn mag_gate_rejects_a_ten_sigma_heading_outlier() {
    let params = EkfParams { mag_noise_gauss: 0.01, ..EkfParams::default() };
    let mut bench = settled(params);
    let sigma = bench.ekf.status().mag_field[1].variance.sqrt();
    let before = *bench.ekf.delayed_state().unwrap();
    // A field turned about down so that the body-right component is off by 10σ, strength kept.
    let angle = (10.0 * sigma / FIELD_NED[0]).asin();
    let turned = UnitQuaternion::from_euler_angles(0.0, 0.0, angle) * Vector3::from(FIELD_NED);
    let time = Time::from_micros(bench.t_us + 1);
    bench.ekf.push_mag(&MagSample { time, field_gauss: turned.into() }).unwrap();
    bench.run(0.3);
    let status = bench.ekf.status();
    assert_eq!(status.mag.rejected, 1, "{status:?}");
    assert!(before.attitude.angle_to(&bench.ekf.delayed_state().unwrap().attitude) < 1e-4);
}

#[test]
fn bad_samples_are_refused_with_a_typed_error() {
    let mut ekf = Ekf::new(EkfParams::default()).unwrap();
    let imu = ImuSample {
        time: Time::from_micros(10),
        gyro_rad_s: [f64::NAN, 0.0, 0.0],
        accel_m_s2: [0.0; 3],
        dt_s: 0.0025,
        gyro_clipped: [false; 3],
        accel_clipped: [false; 3],
    };
    assert!(ekf.push_imu(&imu).unwrap_err().to_string().contains("imu"));
    let imu = ImuSample { gyro_rad_s: [0.0; 3], dt_s: -1.0, accel_clipped: [true; 3], ..imu };
    assert!(ekf.push_imu(&imu).is_err());
    assert_eq!(ekf.status().health.imu_rejected, 2);
    assert_eq!(ekf.status().health.imu_clipped, 0, "a rejected sample is not counted as clipped");

    assert!(Ekf::new(EkfParams { gps_gate_sigma: 0.0, ..EkfParams::default() }).is_err());
}

/// A clipped sample is used (time moves on) and counted once per sample, whatever its axes.
#[test]
fn clipped_imu_samples_are_used_and_counted() {
    let mut bench = settled(EkfParams::default());
    let before = bench.ekf.status().time;
    for (k, (gyro_clipped, accel_clipped)) in
        [([false; 3], [false, false, true]), ([true, false, false], [false; 3]), ([false; 3], [false; 3])]
            .into_iter()
            .enumerate()
    {
        bench.t_us += 2500;
        let imu = ImuSample { gyro_clipped, accel_clipped, ..still_imu(Time::from_micros(bench.t_us)) };
        bench.ekf.push_imu(&imu).unwrap_or_else(|e| panic!("sample {k}: {e}"));
    }
    let status = bench.ekf.status();
    assert_eq!(status.health.imu_clipped, 2, "{status:?}");
    assert_eq!(status.health.imu_rejected, 0);
    assert!(status.time > before);
}

/// For each sensor: a sample older than the delayed fusion horizon, one whose stamp goes back
/// behind the last accepted one, and one stamped a second ahead are each refused with their own
/// error and counted, and fusion goes on at every sensor's full rate afterwards (a future sample
/// let in would hold its buffer for a second).
#[test]
fn stale_backwards_and_future_samples_are_counted_and_do_not_block_fusion() {
    let mut bench = settled(EkfParams::default());
    let before = bench.ekf.status();
    let now = bench.t_us;
    let horizon = bench.ekf.delayed_state().unwrap().time;
    assert_eq!(horizon, Time::from_micros(now - 220_000));
    let at = |us: u64| Time::from_micros(us);
    let stale = at(now - 500_000);
    let backwards = at(now - 100_000);
    let future = at(now + 1_000_000);
    for time in [stale, backwards, future] {
        let fix = GpsFix { time, ..bench.gps([0.0; 3]) };
        let baro = BaroSample { time, pressure_pa: 101_000.0, altitude_m: 20.0, temperature_c: 25.0 };
        let mag = MagSample { time, field_gauss: FIELD_NED };
        let errors = [bench.ekf.push_gps(&fix), bench.ekf.push_baro(&baro), bench.ekf.push_mag(&mag)];
        for e in errors {
            let e = e.unwrap_err();
            let expected = match time {
                t if t == stale => matches!(e, InputError::BehindHorizon { .. }),
                t if t == backwards => matches!(e, InputError::OutOfOrder { .. }),
                _ => matches!(e, InputError::FromFuture { .. }),
            };
            assert!(expected, "{time}: {e}");
        }
    }
    assert_eq!(bench.ekf.dropped_samples(), DroppedSamples { gps: 3, baro: 3, mag: 3 });
    bench.run(1.0);
    let after = bench.ekf.status();
    // One second of fusion at 5, 10 and 100 Hz.
    assert_eq!(after.gps.fused - before.gps.fused, 5, "{after:?}");
    assert!(after.baro.fused - before.baro.fused >= 10, "{after:?}");
    assert_eq!(after.mag.fused - before.mag.fused, 100, "{after:?}");
    assert!((after.fusion_horizon_s - 0.22).abs() < 1e-9, "{after:?}");
    assert_eq!(bench.ekf.dropped_samples(), DroppedSamples { gps: 3, baro: 3, mag: 3 });
}

/// A fix arriving 30 ms later than its nominal 0.22 s lag (UART, task and mailbox jitter on a
/// loaded board) is refused as behind the horizon without an arrival margin, and fused with one
/// of 50 ms, whose horizon runs that much further behind.
#[test]
fn a_margin_lets_a_late_arrival_in_and_moves_the_horizon_back() {
    for (margin_s, fused) in [(0.0, false), (0.05, true)] {
        let mut bench = settled(EkfParams { arrival_margin_s: margin_s, ..EkfParams::default() });
        // Half a second of IMU only, so that the fix below comes after the last one accepted.
        for _ in 0..200 {
            bench.t_us += 2500;
            bench.ekf.push_imu(&still_imu(Time::from_micros(bench.t_us))).unwrap();
        }
        let horizon = bench.ekf.delayed_state().unwrap().time;
        assert_eq!(horizon, Time::from_micros(bench.t_us - 220_000 - (margin_s * 1e6) as u64));
        let late = GpsFix { time: Time::from_micros(bench.t_us - 250_000), ..bench.gps([0.0; 3]) };
        let result = bench.ekf.push_gps(&late);
        assert_eq!(result.is_ok(), fused, "margin {margin_s} s: {result:?}");
        if !fused {
            assert!(matches!(result, Err(InputError::BehindHorizon { .. })), "{result:?}");
        }
    }
}

#[test]
fn a_margin_that_takes_the_horizon_past_the_delay_buffer_is_refused_by_name() {
    for margin_s in [-0.01, f64::NAN, 0.9] {
        let params = EkfParams { arrival_margin_s: margin_s, ..EkfParams::default() };
        let e = params.validate().unwrap_err();
        assert!(e.to_string().contains("arrival_margin_s"), "{margin_s}: {e}");
    }
}

/// Vertical velocity error (m/s, NED down) of the output a second after one clipped sample that
/// understated a touchdown by 0.3 m/s, on a still vehicle with GPS and baro: with
/// `accel_clip_velocity_noise_m_s` at `noise`.
fn error_after_a_clipped_touchdown(noise: f64) -> f64 {
    let mut bench = settled(EkfParams { accel_clip_velocity_noise_m_s: noise, ..EkfParams::default() });
    bench.t_us += 2500;
    let time = Time::from_micros(bench.t_us);
    // The clipped reading misses 120 m/s² of the stop's deceleration: 0.3 m/s of descent left.
    let clipped = ImuSample {
        accel_m_s2: [0.0, 0.0, -GRAVITY_M_S2 + 120.0],
        accel_clipped: [false, false, true],
        ..still_imu(time)
    };
    bench.ekf.push_imu(&clipped).unwrap();
    bench.run(1.5);
    bench.ekf.nav_state().expect("running").velocity_ned_m_s[2]
}

#[test]
fn a_clipped_accelerometer_sample_makes_the_velocity_uncertain_so_the_aiding_takes_its_error_out() {
    let inflated = error_after_a_clipped_touchdown(EkfParams::default().accel_clip_velocity_noise_m_s);
    let confident = error_after_a_clipped_touchdown(1e-6);
    println!(
        "figure: vertical velocity error 1.5 s after a clipped 0.3 m/s: {inflated:.3} m/s inflated, {confident:.3} m/s without"
    );
    assert!(inflated.abs() < 0.05, "{inflated}");
    assert!(
        confident.abs() > 3.0 * inflated.abs(),
        "the test sees the difference: {confident} vs {inflated}"
    );
}
