//! `BackupAttitude`: the attitude, height and climb rate the loop flies on when the estimator's
//! NavState is gone (stale, or its actor failed for good), as ArduPilot falls back from EKF3 to
//! its DCM attitude.
//!
//! A complementary filter fed the raw IMU, magnetometer and barometer beside the loop, always
//! running, independent of the estimator:
//! * attitude — Mahony's explicit complementary filter with gyro-bias learning, as PX4's
//!   `attitude_estimator_q` (`ATT_W_ACC` 0.2, `ATT_W_MAG` 0.1, `ATT_W_GYRO_BIAS` 0.1,
//!   `ATT_BIAS_MAX` 0.05 rad/s): the accelerometer pulls the estimated "down" towards the
//!   measured one when its norm is within 10 % of g, the tilt-compensated compass pulls the
//!   heading, and the bias integrates the correction while the body turns slower than 10°/s;
//! * vertical — a third-order complementary filter of barometer and earth-frame accelerometer
//!   (ArduPilot's `AP_InertialNav` of Copter 3.x): height and climb rate from the acceleration,
//!   corrected by the barometer's height error with gains 3/τ, 3/τ², 1/τ³, the last learning the
//!   vertical accelerometer bias; the barometer's reading is held between samples.
//!
//! Horizontal position and velocity are not observed: the state it gives says so
//! (`NavValidity`), and the controller flies level on it with the drift accepted (ArduCopter's
//! LAND without position). While the estimator flies, [`BackupAttitude::follow`] keeps the
//! estimator's heading, height datum, horizontal position and origin, so a switch continues
//! from where the estimator left off; the tilt is the filter's own.
//!
//! Pure and allocation-free: the real-time thread calls it every iteration. Held by the tests
//! in this file (against synthetic rotations with known truth) and by
//! `tests/backup_attitude_flight.rs` (the estimator failing for good in flight).

use kestrel_proto::Time;
use kestrel_proto::attitude::{angle_difference_rad, quaternion_from_euler, wxyz};
use kestrel_proto::geo::Geodetic;
use kestrel_proto::messages::{BaroSample, ImuSample, MagSample, NavState, NavValidity};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, positive, within};
use crate::position::yaw_of;

const GRAVITY_M_S2: f64 = 9.80665;
/// The accelerometer corrects the tilt only while its norm is within this share of g (PX4's
/// `attitude_estimator_q` without GPS acceleration compensation).
const ACCEL_NORM_BAND: f64 = 0.1;
/// Gyro bias is learnt only below this body rate (rad/s, 10°/s; PX4's `attitude_estimator_q`).
const BIAS_LEARN_MAX_RATE_RAD_S: f64 = 0.175;
/// The alignment multiplies the attitude gains by this, so the first readings settle it fast.
const ALIGN_GAIN: f64 = 10.0;
/// Longest IMU step integrated (s): a longer gap is taken as this long.
const MAX_DT_S: f64 = 0.02;
/// The estimator not followed for this long (s): the backup is flying, and holds its gyro bias.
const FOLLOW_LAPSE_S: f64 = 0.1;

/// `[actors.controller.params.control.backup]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BackupAttitudeParams {
    /// Weight of the accelerometer's tilt correction (rad/s per unit of the cross product of the
    /// unit vectors; PX4 `ATT_W_ACC`).
    pub accel_weight: f64,
    /// Weight of the compass's heading correction (rad/s per rad; PX4 `ATT_W_MAG`).
    pub mag_weight: f64,
    /// Gyro-bias learning weight (1/s; PX4 `ATT_W_GYRO_BIAS`).
    pub gyro_bias_weight: f64,
    /// Largest gyro bias learnt per axis (rad/s; PX4 `ATT_BIAS_MAX`).
    pub max_gyro_bias_rad_s: f64,
    /// Time after the first IMU sample with the attitude gains raised tenfold (s); the state is
    /// not flown before it ends.
    pub align_s: f64,
    /// Time constant of the barometer/accelerometer height filter (s; ArduPilot's
    /// `INAV_TC_Z`, 5 s on Copter 3.x; shorter here, the barometer being the only height).
    pub height_time_constant_s: f64,
    /// Magnetic declination (deg, east positive): true heading = magnetic heading + this.
    pub mag_declination_deg: f64,
    /// No IMU sample within this (s): the backup is not flown either.
    pub imu_timeout_s: f64,
    /// A compass sample older than this (s) no longer corrects the heading.
    pub mag_timeout_s: f64,
    /// A barometer sample older than this (s) no longer corrects the height, which is then
    /// reported unobserved.
    pub baro_timeout_s: f64,
}

impl Default for BackupAttitudeParams {
    fn default() -> BackupAttitudeParams {
        BackupAttitudeParams {
            accel_weight: 0.2,
            mag_weight: 0.1,
            gyro_bias_weight: 0.1,
            max_gyro_bias_rad_s: 0.05,
            align_s: 2.0,
            height_time_constant_s: 2.0,
            mag_declination_deg: 0.0,
            imu_timeout_s: 0.05,
            mag_timeout_s: 0.5,
            baro_timeout_s: 0.5,
        }
    }
}

impl BackupAttitudeParams {
    /// Checks every field; the error names the first offending one (under `backup.`).
    pub fn validate(&self) -> Result<(), InvalidParam> {
        within("backup.accel_weight", self.accel_weight, 0.0, 10.0)?;
        within("backup.mag_weight", self.mag_weight, 0.0, 10.0)?;
        within("backup.gyro_bias_weight", self.gyro_bias_weight, 0.0, 10.0)?;
        within("backup.max_gyro_bias_rad_s", self.max_gyro_bias_rad_s, 0.0, 1.0)?;
        within("backup.align_s", self.align_s, 0.0, 60.0)?;
        within("backup.height_time_constant_s", self.height_time_constant_s, 0.5, 30.0)?;
        within("backup.mag_declination_deg", self.mag_declination_deg, -180.0, 180.0)?;
        positive("backup.imu_timeout_s", self.imu_timeout_s)?;
        positive("backup.mag_timeout_s", self.mag_timeout_s)?;
        positive("backup.baro_timeout_s", self.baro_timeout_s)
    }
}

/// The part of an [`ImuSample`] the filter uses, `Copy` so the real-time thread can take it
/// from a sample ring.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImuReading {
    pub time: Time,
    /// Body FRD rate (rad/s).
    pub gyro_rad_s: [f64; 3],
    /// Body FRD specific force (m/s²): about `[0, 0, -9.81]` at rest.
    pub accel_m_s2: [f64; 3],
    /// The accelerometer was at full scale: its direction says nothing of the tilt.
    pub accel_clipped: bool,
}

impl From<&ImuSample> for ImuReading {
    fn from(s: &ImuSample) -> ImuReading {
        ImuReading {
            time: s.time,
            gyro_rad_s: s.gyro_rad_s,
            accel_m_s2: s.accel_m_s2,
            accel_clipped: s.accel_clipped.iter().any(|&c| c),
        }
    }
}

/// A sample the filter refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum BackupInputError {
    #[error("IMU sample refused: a gyro or accelerometer value is not finite")]
    NonFiniteImu,
    #[error("IMU sample refused: its time is not after the previous one's")]
    ImuTimeNotIncreasing,
    #[error("magnetometer sample refused: the field is not finite, or zero")]
    BadMag,
    #[error("barometer sample refused: the altitude is not finite")]
    BadBaro,
}

/// What the filter refused so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BackupCounters {
    pub rejected_imu: u64,
    pub rejected_mag: u64,
    pub rejected_baro: u64,
}

/// What the estimator said last, kept so a switch continues from it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Datum {
    /// The estimator has been followed once: before, there is nothing to continue from (and
    /// the vehicle, which arms on the estimator, is on the ground).
    set: bool,
    /// Estimator heading minus the filter's (rad).
    yaw_offset_rad: f64,
    /// Estimator down minus the filter's (m).
    down_offset_m: f64,
    north_east_m: [f64; 2],
    origin: Option<Geodetic>,
}

/// The barometer/accelerometer height filter, down positive from the first barometer reading.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Vertical {
    down_m: f64,
    velocity_down_m_s: f64,
    /// Learnt vertical accelerometer bias (m/s², earth down).
    accel_bias_m_s2: f64,
    /// Altitude of the first barometer reading (m above MSL): the filter's zero.
    reference_m: Option<f64>,
    /// The newest barometer reading as height down from the reference (m), held until the next
    /// one, and its time: each IMU step corrects by its difference from the filter's height.
    measured_down_m: f64,
    measured_at: Option<Time>,
}

/// The backup attitude and vertical filter. See the module docs.
#[derive(Clone, Debug)]
pub struct BackupAttitude {
    params: BackupAttitudeParams,
    /// Body FRD → NED.
    q: UnitQuaternion<f64>,
    gyro_bias_rad_s: Vector3<f64>,
    /// Bias-corrected rate of the newest sample (rad/s).
    rate_rad_s: Vector3<f64>,
    first_imu: Option<Time>,
    last_imu: Option<Time>,
    /// Newest compass field (body FRD, gauss) and its time.
    mag: Option<(Time, Vector3<f64>)>,
    vertical: Vertical,
    datum: Datum,
    /// When the estimator's state was last followed.
    last_follow: Option<Time>,
    counters: BackupCounters,
}

impl BackupAttitude {
    pub fn new(params: BackupAttitudeParams) -> Result<BackupAttitude, InvalidParam> {
        params.validate()?;
        Ok(BackupAttitude {
            params,
            q: UnitQuaternion::identity(),
            gyro_bias_rad_s: Vector3::zeros(),
            rate_rad_s: Vector3::zeros(),
            first_imu: None,
            last_imu: None,
            mag: None,
            vertical: Vertical::default(),
            datum: Datum::default(),
            last_follow: None,
            counters: BackupCounters::default(),
        })
    }

    /// The attitude (body FRD → NED) of the filter itself, without the estimator's heading.
    pub fn attitude(&self) -> UnitQuaternion<f64> {
        self.q
    }

    /// The learnt gyro bias (body FRD, rad/s).
    pub fn gyro_bias_rad_s(&self) -> Vector3<f64> {
        self.gyro_bias_rad_s
    }

    /// Height down from the first barometer reading (m) and its rate (m/s).
    pub fn vertical_down(&self) -> (f64, f64) {
        (self.vertical.down_m, self.vertical.velocity_down_m_s)
    }

    pub fn counters(&self) -> BackupCounters {
        self.counters
    }

    /// Aligned: past `align_s` of IMU samples.
    pub fn aligned(&self) -> bool {
        match (self.first_imu, self.last_imu) {
            (Some(first), Some(last)) => last.saturating_since(first).as_secs_f64() >= self.params.align_s,
            _ => false,
        }
    }

    /// A compass sample; the next IMU steps correct the heading with it.
    pub fn on_mag(&mut self, mag: &MagSample) -> Result<(), BackupInputError> {
        let field = Vector3::from(mag.field_gauss);
        if !field.iter().all(|v| v.is_finite()) || field.norm() < 1e-6 {
            self.counters.rejected_mag += 1;
            return Err(BackupInputError::BadMag);
        }
        self.mag = Some((mag.time, field));
        Ok(())
    }

    /// A barometer sample: the height error the next IMU steps correct.
    pub fn on_baro(&mut self, baro: &BaroSample) -> Result<(), BackupInputError> {
        if !baro.altitude_m.is_finite() {
            self.counters.rejected_baro += 1;
            return Err(BackupInputError::BadBaro);
        }
        let v = &mut self.vertical;
        let reference = *v.reference_m.get_or_insert_with(|| {
            v.down_m = 0.0;
            v.velocity_down_m_s = 0.0;
            baro.altitude_m
        });
        v.measured_down_m = reference - baro.altitude_m;
        v.measured_at = Some(baro.time);
        Ok(())
    }

    /// One IMU step: the attitude integrated and corrected, then the height.
    pub fn on_imu(&mut self, imu: &ImuReading) -> Result<(), BackupInputError> {
        let gyro = Vector3::from(imu.gyro_rad_s);
        let accel = Vector3::from(imu.accel_m_s2);
        if !gyro.iter().chain(accel.iter()).all(|v| v.is_finite()) {
            self.counters.rejected_imu += 1;
            return Err(BackupInputError::NonFiniteImu);
        }
        let Some(last) = self.last_imu else {
            self.first_imu = Some(imu.time);
            self.last_imu = Some(imu.time);
            self.align_from(&accel, imu.time);
            self.rate_rad_s = gyro - self.gyro_bias_rad_s;
            return Ok(());
        };
        if imu.time <= last {
            self.counters.rejected_imu += 1;
            return Err(BackupInputError::ImuTimeNotIncreasing);
        }
        let dt = imu.time.saturating_since(last).as_secs_f64().min(MAX_DT_S);
        self.last_imu = Some(imu.time);
        self.attitude_step(&gyro, &accel, !imu.accel_clipped, imu.time, dt);
        self.vertical_step(&accel, imu.time, dt);
        Ok(())
    }

    /// Roll and pitch from the first specific force, heading from the compass if one is known
    /// (PX4's `attitude_estimator_q` initialisation).
    fn align_from(&mut self, accel: &Vector3<f64>, now: Time) {
        if accel.norm() < 1e-6 {
            return;
        }
        // At rest the specific force points up: body "down" is its opposite.
        let down = -accel.normalize();
        let roll = down.y.atan2(down.z);
        let pitch = (-down.x).clamp(-1.0, 1.0).asin();
        let level = unit(quaternion_from_euler(roll, pitch, 0.0));
        let yaw = self.fresh_mag(now).map_or(0.0, |m| {
            let h = level * m;
            -h.y.atan2(h.x) + self.params.mag_declination_deg.to_radians()
        });
        self.q = unit(quaternion_from_euler(roll, pitch, yaw));
    }

    fn fresh_mag(&self, now: Time) -> Option<Vector3<f64>> {
        self.mag
            .filter(|(t, _)| now.saturating_since(*t).as_secs_f64() <= self.params.mag_timeout_s)
            .map(|(_, m)| m)
    }

    fn attitude_step(
        &mut self,
        gyro: &Vector3<f64>,
        accel: &Vector3<f64>,
        accel_ok: bool,
        now: Time,
        dt: f64,
    ) {
        let p = self.params;
        let boost = if self.aligned() { 1.0 } else { ALIGN_GAIN };
        let mut correction = Vector3::zeros();
        // Tilt: estimated body "down" × measured "down" (the opposite of the specific force).
        let norm = accel.norm();
        if accel_ok && (norm - GRAVITY_M_S2).abs() < ACCEL_NORM_BAND * GRAVITY_M_S2 {
            let down_est = self.q.inverse_transform_vector(&Vector3::z());
            correction += down_est.cross(&(accel / norm)) * (p.accel_weight * boost);
        }
        // Heading: the compass's horizontal field in NED should point to magnetic north.
        if let Some(m) = self.fresh_mag(now) {
            let m_ned = self.q * m;
            if m_ned.x.hypot(m_ned.y) > 1e-6 {
                // Positive: the estimate's heading is that much past the compass's.
                let error = angle_difference_rad(m_ned.y.atan2(m_ned.x), p.mag_declination_deg.to_radians());
                correction +=
                    self.q.inverse_transform_vector(&Vector3::new(0.0, 0.0, -error)) * (p.mag_weight * boost);
            }
        }
        // Flying on its own (the estimator followed once, not lately) the bias is held: a
        // multirotor's accelerometer reads drag as tilt, and the level attitude flown on the
        // estimate closes a loop (velocity → drag → tilt error → velocity) that the bias
        // integrator would make marginal (s³ + c·s² + k·c·s + k·c·w, c the drag rate ≈ 0.1/s,
        // k = ATT_W_ACC, w = ATT_W_GYRO_BIAS = 0.1 ≈ c); without it, s² + c·s + k·c is damped.
        // Held by `tests/flight_faults.rs` (the estimator failing for good in forward flight).
        let flying_alone =
            self.last_follow.is_some_and(|t| now.saturating_since(t).as_secs_f64() > FOLLOW_LAPSE_S);
        let spin = (gyro - self.gyro_bias_rad_s).norm();
        if spin < BIAS_LEARN_MAX_RATE_RAD_S && !flying_alone {
            let max = p.max_gyro_bias_rad_s;
            self.gyro_bias_rad_s -= correction * (p.gyro_bias_weight * dt);
            self.gyro_bias_rad_s = self.gyro_bias_rad_s.map(|b| b.clamp(-max, max));
        }
        self.rate_rad_s = gyro - self.gyro_bias_rad_s;
        let omega = self.rate_rad_s + correction;
        self.q *= UnitQuaternion::from_scaled_axis(omega * dt);
        self.q.renormalize_fast();
    }

    fn vertical_step(&mut self, accel: &Vector3<f64>, now: Time, dt: f64) {
        let tau = self.params.height_time_constant_s;
        let (k1, k2, k3) = (3.0 / tau, 3.0 / (tau * tau), 1.0 / (tau * tau * tau));
        let v = &mut self.vertical;
        // Kinematic acceleration down: specific force in NED plus gravity.
        let accel_down = (self.q * accel).z + GRAVITY_M_S2 - v.accel_bias_m_s2;
        let error = match v.measured_at {
            Some(t) if now.saturating_since(t).as_secs_f64() <= self.params.baro_timeout_s => {
                v.measured_down_m - v.down_m
            }
            _ => 0.0,
        };
        v.accel_bias_m_s2 -= k3 * error * dt;
        v.velocity_down_m_s += (accel_down + k2 * error) * dt;
        v.down_m += (v.velocity_down_m_s + k1 * error) * dt;
    }

    /// Keeps the estimator's heading, height datum, horizontal position and origin while it
    /// flies (`nav` passed the loop's checks), so a switch continues from them.
    pub fn follow(&mut self, nav: &NavState) {
        if !self.aligned() {
            return;
        }
        self.last_follow = Some(nav.time);
        let Ok(q) = kestrel_proto::attitude::unit_quaternion(nav.attitude) else { return };
        if nav.valid.attitude {
            self.datum.set = true;
            self.datum.yaw_offset_rad = angle_difference_rad(yaw_of(&q), yaw_of(&self.q));
        }
        if nav.valid.vertical_position {
            self.datum.down_offset_m = nav.position_ned_m[2] - self.vertical.down_m;
        }
        if nav.valid.horizontal_position {
            self.datum.north_east_m = [nav.position_ned_m[0], nav.position_ned_m[1]];
        }
        self.datum.origin = nav.origin.or(self.datum.origin);
    }

    /// The state to fly at `now`, when aligned, the IMU is fresh and the estimator has been
    /// followed (see [`BackupAttitude::follow`]; none at boot): the filter's tilt, the
    /// estimator's last heading offset applied, the barometer's height on the estimator's last
    /// datum; north/east frozen where the estimator last had them and flagged unobserved.
    pub fn nav_state(&self, now: Time) -> Option<NavState> {
        let last = self.last_imu?;
        let imu_stale = now.saturating_since(last).as_secs_f64() > self.params.imu_timeout_s;
        if !self.aligned() || !self.datum.set || imu_stale {
            return None;
        }
        let heading = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), self.datum.yaw_offset_rad);
        let q = heading * self.q;
        let v = &self.vertical;
        let baro = v
            .measured_at
            .is_some_and(|t| last.saturating_since(t).as_secs_f64() <= self.params.baro_timeout_s);
        let [north, east] = self.datum.north_east_m;
        Some(NavState {
            time: last,
            attitude: wxyz(&q),
            angular_velocity_rad_s: self.rate_rad_s.into(),
            velocity_ned_m_s: [0.0, 0.0, v.velocity_down_m_s],
            position_ned_m: [north, east, v.down_m + self.datum.down_offset_m],
            gyro_bias_rad_s: self.gyro_bias_rad_s.into(),
            accel_bias_m_s2: [0.0, 0.0, v.accel_bias_m_s2],
            // Not estimated: the filter keeps no covariance.
            covariance_diagonal: [0.0; 16],
            origin: self.datum.origin,
            valid: NavValidity {
                attitude: true,
                horizontal_velocity: false,
                horizontal_velocity_from_drag: false,
                horizontal_position: false,
                vertical_velocity: baro,
                vertical_position: baro,
            },
        })
    }
}

/// `[w, x, y, z]` of a rotation built here (finite by construction) as a unit quaternion.
fn unit(q: [f64; 4]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]))
}

#[cfg(test)]
mod tests;
