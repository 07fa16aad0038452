//! The filter against synthetic motions whose truth is known in closed form: body rates from
//! finite differences of the true attitude, specific force and compass field rotated from NED
//! by the true attitude.

use kestrel_proto::attitude::euler_rad;
use proptest::prelude::*;

use super::*;

const RATE_HZ: f64 = 400.0;
/// Earth field at Moratuwa, roughly (gauss, NED): mostly north, slightly up.
const FIELD_NED: [f64; 3] = [0.39, 0.0, -0.05];

fn at(s: f64) -> Time {
    Time::from_micros((s * 1e6).round() as u64)
}

/// Body rate of the motion `truth` at `t` (rad/s, FRD): the rotation between two instants
/// 1 ms apart, over that time (central difference).
fn body_rate(truth: &impl Fn(f64) -> UnitQuaternion<f64>, t: f64) -> Vector3<f64> {
    let h = 1e-3;
    (truth(t - h / 2.0).inverse() * truth(t + h / 2.0)).scaled_axis() / h
}

/// What the sensors of a vehicle rotating in place along `truth` read at `t`.
struct Sensors {
    gyro_bias: Vector3<f64>,
    accel_bias: Vector3<f64>,
    mag: bool,
    /// The earth's field (gauss, NED).
    field_ned: Vector3<f64>,
}

impl Sensors {
    fn clean() -> Sensors {
        Sensors {
            gyro_bias: Vector3::zeros(),
            accel_bias: Vector3::zeros(),
            mag: true,
            field_ned: FIELD_NED.into(),
        }
    }
}

/// Runs the filter over `seconds` of `truth` (rotating in place: no linear acceleration) with
/// a barometer at a constant height; returns it.
fn fly(
    filter: &mut BackupAttitude,
    truth: &impl Fn(f64) -> UnitQuaternion<f64>,
    from_s: f64,
    seconds: f64,
    sensors: &Sensors,
) {
    let steps = (seconds * RATE_HZ).round() as u64;
    for k in 0..steps {
        let t = from_s + k as f64 / RATE_HZ;
        let q = truth(t);
        if sensors.mag && k % 4 == 0 {
            let field = q.inverse_transform_vector(&sensors.field_ned);
            filter.on_mag(&MagSample { time: at(t), field_gauss: field.into() }).expect("mag");
        }
        if k % 40 == 0 {
            let baro =
                BaroSample { time: at(t), pressure_pa: 101_000.0, altitude_m: 20.0, temperature_c: 25.0 };
            filter.on_baro(&baro).expect("baro");
        }
        let accel = q.inverse_transform_vector(&Vector3::new(0.0, 0.0, -GRAVITY_M_S2)) + sensors.accel_bias;
        let gyro = body_rate(truth, t) + sensors.gyro_bias;
        let imu = ImuReading {
            time: at(t),
            gyro_rad_s: gyro.into(),
            accel_m_s2: accel.into(),
            accel_clipped: false,
        };
        filter.on_imu(&imu).expect("imu");
    }
}

fn filter() -> BackupAttitude {
    BackupAttitude::new(BackupAttitudeParams::default()).expect("defaults valid")
}

/// Angle of the rotation between `a` and `b` (deg).
fn error_deg(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> f64 {
    a.angle_to(b).to_degrees()
}

/// Angle between the two attitudes' down axes (deg): the tilt error, heading left out.
fn tilt_error_deg(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> f64 {
    (a * Vector3::z()).angle(&(b * Vector3::z())).to_degrees()
}

fn euler(roll: f64, pitch: f64, yaw: f64) -> UnitQuaternion<f64> {
    unit(quaternion_from_euler(roll, pitch, yaw))
}

/// A tumbling motion: roll, pitch and heading swinging on different periods, up to 35° of tilt.
fn tumbling(t: f64) -> UnitQuaternion<f64> {
    euler(0.5 * (0.9 * t).sin(), 0.4 * (0.6 * t + 1.0).sin(), 0.3 * t + 0.8 * (0.25 * t).sin())
}

#[test]
fn a_tumbling_rotation_is_tracked_to_within_a_degree() {
    let mut f = filter();
    fly(&mut f, &tumbling, 0.0, 60.0, &Sensors::clean());
    let t = 60.0 - 1.0 / RATE_HZ;
    let err = error_deg(&f.attitude(), &tumbling(t));
    // The accelerometer is exact here (no linear acceleration), the compass too: what is left
    // is integration error, corrected continuously.
    assert!(err < 1.0, "attitude error {err:.3}° after 60 s");
}

#[test]
fn the_first_sample_aligns_roll_and_pitch_from_the_accelerometer_and_heading_from_the_compass() {
    let truth = |_: f64| euler(20f64.to_radians(), -10f64.to_radians(), 1.0);
    let mut f = filter();
    // The compass first, so the alignment has it.
    let field = truth(0.0).inverse_transform_vector(&Vector3::from(FIELD_NED));
    f.on_mag(&MagSample { time: at(0.0), field_gauss: field.into() }).expect("mag");
    fly(&mut f, &truth, 0.0, 1.0 / RATE_HZ, &Sensors::clean());
    let [roll, pitch, yaw] = euler_rad(wxyz(&f.attitude()));
    assert!((roll.to_degrees() - 20.0).abs() < 1e-6, "roll {}", roll.to_degrees());
    assert!((pitch.to_degrees() + 10.0).abs() < 1e-6, "pitch {}", pitch.to_degrees());
    assert!((yaw - 1.0).abs() < 1e-6, "yaw {yaw}");
}

#[test]
fn with_the_accelerometer_alone_a_tilt_the_gyro_missed_is_found() {
    // Aligned level, then tilted 15° in roll and 10° in pitch without a gyro reading of it (as
    // after a gyro saturation): the accelerometer alone pulls roll and pitch to it.
    let mut f = filter();
    let no_mag = Sensors { mag: false, ..Sensors::clean() };
    fly(&mut f, &|_| UnitQuaternion::identity(), 0.0, 3.0, &no_mag);
    let tilted = euler(15f64.to_radians(), 10f64.to_radians(), 0.0);
    fly(&mut f, &|_| tilted, 3.0, 60.0, &no_mag);
    let err = tilt_error_deg(&f.attitude(), &tilted);
    // ATT_W_ACC 0.2 with ATT_W_GYRO_BIAS 0.1: s² + 0.2 s + 0.02, an envelope of e^(-0.1 t);
    // 60 s leave about e^-6 of 18°, 0.05°.
    assert!(err < 0.5, "tilt error {err:.3}° after 60 s");
}

#[test]
fn a_constant_gyro_bias_is_learnt_and_taken_off() {
    let bias = Vector3::new(0.02, -0.015, 0.01);
    let mut f = filter();
    let sensors = Sensors { gyro_bias: bias, ..Sensors::clean() };
    let still = |_: f64| euler(0.05, -0.03, 0.7);
    fly(&mut f, &still, 0.0, 120.0, &sensors);
    let learnt = f.gyro_bias_rad_s();
    assert!((learnt - bias).norm() < 0.002, "learnt {learnt:?}, true {bias:?}");
    assert!(error_deg(&f.attitude(), &still(0.0)) < 0.5, "{:.3}°", error_deg(&f.attitude(), &still(0.0)));
}

#[test]
fn a_heading_the_gyro_missed_is_pulled_to_the_compass_with_its_declination() {
    // Magnetic north 10° east of true north, and the filter told so.
    let declination = 10f64.to_radians();
    let params = BackupAttitudeParams { mag_declination_deg: 10.0, ..BackupAttitudeParams::default() };
    let mut f = BackupAttitude::new(params).expect("valid");
    let field_ned =
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), declination) * Vector3::from(FIELD_NED);
    let sensors = Sensors { field_ned, ..Sensors::clean() };
    let no_mag = Sensors { mag: false, ..Sensors::clean() };
    // Aligned without a compass (heading 0), facing 40° east of true north in truth.
    let truth = |_: f64| euler(0.1, -0.05, 40f64.to_radians());
    fly(&mut f, &truth, 0.0, 3.0, &no_mag);
    let yaw = euler_rad(wxyz(&f.attitude()))[2];
    assert!(yaw.abs() < 0.01, "no compass: the first sample's heading, 0: {yaw}");
    // Then the compass: ATT_W_MAG 0.1 with the bias learning, s² + 0.1 s + 0.01, an envelope
    // of e^(-0.05 t); 120 s leave about e^-6 of 40°, 0.1°.
    fly(&mut f, &truth, 3.0, 120.0, &sensors);
    let yaw = euler_rad(wxyz(&f.attitude()))[2];
    assert!((yaw.to_degrees() - 40.0).abs() < 0.5, "heading {:.3}°", yaw.to_degrees());
}

#[test]
fn flying_on_its_own_after_the_estimator_the_gyro_bias_is_held() {
    let bias = Vector3::new(0.01, -0.01, 0.0);
    let still = |_: f64| UnitQuaternion::identity();
    let sensors = Sensors { gyro_bias: bias, ..Sensors::clean() };
    let mut f = filter();
    fly(&mut f, &still, 0.0, 60.0, &sensors);
    let learnt = f.gyro_bias_rad_s();
    assert!((learnt - bias).norm() < 0.002, "learnt on its own before the estimator: {learnt:?}");
    f.follow(&NavState::exact(at(60.0), [1.0, 0.0, 0.0, 0.0], [0.0; 3], [0.0; 3], [0.0; 3]));
    // The estimator gone, a gyro whose bias moves: the backup keeps what it learnt.
    let moved = Sensors { gyro_bias: bias * 2.0, ..Sensors::clean() };
    fly(&mut f, &still, 60.0, 30.0, &moved);
    // Learning on, it would have moved by 0.014 rad/s towards the new bias; held, it moves only
    // in the `FOLLOW_LAPSE_S` after the last state followed.
    let moved_by = (f.gyro_bias_rad_s() - learnt).norm();
    assert!(moved_by < 1e-4, "held while flying alone: moved by {moved_by}");
}

#[test]
fn without_a_compass_the_heading_holds_on_the_gyro() {
    let mut f = filter();
    let no_mag = Sensors { mag: false, ..Sensors::clean() };
    // Aligned with no compass: heading 0; then a turn of 90° in 3 s, tracked by the gyro alone.
    let turn = |t: f64| euler(0.0, 0.0, (t - 3.0).clamp(0.0, 3.0) * std::f64::consts::FRAC_PI_6);
    fly(&mut f, &turn, 0.0, 8.0, &no_mag);
    let yaw = euler_rad(wxyz(&f.attitude()))[2];
    assert!((yaw.to_degrees() - 90.0).abs() < 0.5, "heading {:.3}°", yaw.to_degrees());
}

/// The vertical channel: a climb at 2 m/s from 2 s to 7 s, accelerating and braking over half a
/// second each, with an accelerometer biased 0.3 m/s² along body down.
#[test]
fn the_height_and_climb_rate_follow_the_barometer_and_learn_the_accelerometer_bias() {
    let accel_bias = 0.3;
    // Height up (m) and its derivatives, piecewise: rest, ramp up, climb, ramp down, rest.
    let profile = |t: f64| -> (f64, f64, f64) {
        let v = 2.0;
        let a = 4.0;
        let seg = |t0: f64| (t - t0).max(0.0);
        // Velocity up: a ramp up from 2 s, down from 7 s.
        let vel = (a * seg(2.0)).min(v) - (a * seg(7.0)).min(v);
        let acc = if (2.0..2.5).contains(&t) {
            a
        } else if (7.0..7.5).contains(&t) {
            -a
        } else {
            0.0
        };
        let integral = |t0: f64| {
            let s = seg(t0);
            if s < 0.5 { 0.5 * a * s * s } else { 0.5 + v * (s - 0.5) }
        };
        (integral(2.0) - integral(7.0), vel, acc)
    };
    let mut f = filter();
    let mut worst_rate = 0.0f64;
    for k in 0..(30.0 * RATE_HZ) as u64 {
        let t = k as f64 / RATE_HZ;
        let (up, vel_up, acc_up) = profile(t);
        if k % 40 == 0 {
            let baro =
                BaroSample { time: at(t), pressure_pa: 0.0, altitude_m: 100.0 + up, temperature_c: 25.0 };
            f.on_baro(&baro).expect("baro");
        }
        let accel = [0.0, 0.0, -GRAVITY_M_S2 - acc_up + accel_bias];
        let imu = ImuReading { time: at(t), gyro_rad_s: [0.0; 3], accel_m_s2: accel, accel_clipped: false };
        f.on_imu(&imu).expect("imu");
        if t > 10.0 {
            worst_rate = worst_rate.max((f.vertical_down().1 + vel_up).abs());
        }
        if (6.0..7.0).contains(&t) {
            // Well into the climb: the climb rate is the truth's within the bias's effect.
            assert!((f.vertical_down().1 + vel_up).abs() < 0.5, "climb rate {:?} at {t}", f.vertical_down());
        }
    }
    let (down, rate) = f.vertical_down();
    assert!((down + 10.0).abs() < 0.05, "height down {down:.3} m, 10 m up expected");
    assert!(rate.abs() < 0.02, "rate {rate:.3} m/s at rest");
    assert!(worst_rate < 0.1, "climb rate error {worst_rate:.3} m/s once the bias is learnt");
    assert!((f.vertical.accel_bias_m_s2 - accel_bias).abs() < 0.05, "bias {:?}", f.vertical);
}

#[test]
fn the_state_is_flown_only_once_aligned_after_the_estimator_and_while_the_imu_is_fresh() {
    let mut f = filter();
    let estimator = NavState::exact(at(1.0), [1.0, 0.0, 0.0, 0.0], [0.0; 3], [0.0; 3], [0.0; 3]);
    fly(&mut f, &|_| UnitQuaternion::identity(), 0.0, 1.0, &Sensors::clean());
    f.follow(&estimator);
    assert!(f.nav_state(at(1.0)).is_none(), "still aligning");
    fly(&mut f, &|_| UnitQuaternion::identity(), 1.0, 2.0, &Sensors::clean());
    assert!(f.nav_state(at(3.0)).is_none(), "aligned, but the estimator never flew: nothing to continue");
    f.follow(&NavState { time: at(3.0), ..estimator });
    let nav = f.nav_state(at(3.0)).expect("aligned, IMU fresh");
    assert!(nav.valid.attitude && nav.valid.vertical_position && nav.valid.vertical_velocity);
    assert!(!nav.valid.horizontal_position && !nav.valid.horizontal_velocity);
    assert!(f.nav_state(at(3.0 + 0.06)).is_none(), "no IMU sample for 60 ms");
}

#[test]
fn following_the_estimator_gives_its_heading_height_and_position_to_the_backup() {
    let mut f = filter();
    let no_mag = Sensors { mag: false, ..Sensors::clean() };
    fly(&mut f, &|_| euler(0.1, 0.0, 0.0), 0.0, 3.0, &no_mag);
    let mut nav = NavState::exact(
        at(3.0),
        quaternion_from_euler(0.1, 0.0, 2.0),
        [0.0; 3],
        [0.0; 3],
        [4.0, -3.0, -12.0],
    );
    nav.origin = Some(Geodetic { lat_deg: 6.8, lon_deg: 79.9, alt_m: 20.0 });
    f.follow(&nav);
    let backup = f.nav_state(at(3.0)).expect("aligned");
    let [roll, _, yaw] = euler_rad(backup.attitude);
    assert!((yaw - 2.0).abs() < 1e-3, "the estimator's heading: {yaw}");
    assert!((roll - 0.1).abs() < 1e-3, "the filter's own roll: {roll}");
    assert!((backup.position_ned_m[0] - 4.0).abs() < 1e-9 && (backup.position_ned_m[1] + 3.0).abs() < 1e-9);
    assert!(
        (backup.position_ned_m[2] + 12.0).abs() < 1e-6,
        "on the estimator's datum: {:?}",
        backup.position_ned_m
    );
    assert_eq!(backup.origin, nav.origin);
}

#[test]
fn bad_samples_are_refused_and_counted() {
    let mut f = filter();
    let good = ImuReading { time: at(1.0), accel_m_s2: [0.0, 0.0, -GRAVITY_M_S2], ..ImuReading::default() };
    f.on_imu(&good).expect("good");
    let nan = ImuReading { time: at(1.1), gyro_rad_s: [f64::NAN, 0.0, 0.0], ..good };
    assert_eq!(f.on_imu(&nan), Err(BackupInputError::NonFiniteImu));
    assert_eq!(f.on_imu(&good), Err(BackupInputError::ImuTimeNotIncreasing));
    assert_eq!(f.on_mag(&MagSample { time: at(1.0), field_gauss: [0.0; 3] }), Err(BackupInputError::BadMag));
    let baro = BaroSample { time: at(1.0), pressure_pa: 0.0, altitude_m: f64::INFINITY, temperature_c: 0.0 };
    assert_eq!(f.on_baro(&baro), Err(BackupInputError::BadBaro));
    assert_eq!(f.counters(), BackupCounters { rejected_imu: 2, rejected_mag: 1, rejected_baro: 1 });
    assert!(f.attitude().coords.iter().all(|v| v.is_finite()));
}

#[test]
fn parameters_out_of_range_are_refused_by_name() {
    let bad = BackupAttitudeParams { height_time_constant_s: 0.0, ..BackupAttitudeParams::default() };
    assert_eq!(BackupAttitude::new(bad).unwrap_err().name, "backup.height_time_constant_s");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    /// Whatever finite rates and forces come, the attitude stays a unit quaternion.
    #[test]
    fn the_quaternion_stays_unit(
        samples in prop::collection::vec((prop::array::uniform3(-30.0f64..30.0), prop::array::uniform3(-160.0f64..160.0)), 1..400)
    ) {
        let mut f = filter();
        for (k, (gyro, accel)) in samples.into_iter().enumerate() {
            let imu = ImuReading { time: at(k as f64 / RATE_HZ), gyro_rad_s: gyro, accel_m_s2: accel, accel_clipped: false };
            f.on_imu(&imu).expect("finite");
            let norm = f.attitude().coords.norm();
            prop_assert!((norm - 1.0).abs() < 1e-9, "norm {norm}");
        }
    }

    /// A gyro bias of up to 0.02 rad/s per axis (1.1°/s, several times what a MEMS gyro keeps
    /// after its start-up calibration) on a vehicle tilted up to 30°, heading anywhere: the tilt
    /// error stays under 6° throughout once aligned — before the bias is learnt it is about
    /// bias/ATT_W_ACC at worst (the scalar model s² + 0.2 s + 0.02 peaks at 4.5° for the
    /// 0.028 rad/s of two such axes) — and ends under half a degree.
    #[test]
    fn a_bounded_bias_leaves_a_bounded_error(
        bias in prop::array::uniform3(-0.02f64..0.02),
        roll in -0.5f64..0.5,
        pitch in -0.5f64..0.5,
        yaw in -3.1f64..3.1,
    ) {
        let truth = euler(roll, pitch, yaw);
        let sensors = Sensors { gyro_bias: Vector3::from(bias), ..Sensors::clean() };
        let mut f = filter();
        fly(&mut f, &|_| truth, 0.0, 2.0, &sensors);
        let mut worst = 0.0f64;
        for s in 0..58 {
            fly(&mut f, &|_| truth, 2.0 + s as f64, 1.0, &sensors);
            worst = worst.max(tilt_error_deg(&f.attitude(), &truth));
        }
        prop_assert!(worst < 6.0, "worst tilt error {worst:.3}°");
        let end = tilt_error_deg(&f.attitude(), &truth);
        prop_assert!(end < 0.5, "tilt error {end:.3}° after 60 s");
    }
}
