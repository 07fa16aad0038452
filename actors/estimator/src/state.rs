//! The filter's state (thesis eq. 3.13), the IMU increments that drive it, and the error-state
//! layout of its covariance.
//!
//! The filter is an error-state (multiplicative) EKF: the nominal state carries the thesis's 16
//! elements (attitude quaternion, NED velocity, NED position, gyro bias, accel bias); the
//! covariance describes a 15-element error `δx = (δθ, δv, δp, δb_g, δb_a)` where the attitude
//! error `δθ` is a small rotation vector in NED, `q_true = Exp(δθ) ⊗ q`. Three attitude error
//! components instead of four quaternion ones keep the covariance full rank and the quaternion
//! exactly normalised (PX4 EKF2 and ArduPilot EKF3 do the same).

use kestrel_proto::Time;
use nalgebra::{SMatrix, SVector, UnitQuaternion, Vector3};

/// Length of the error state.
pub const ERROR_STATES: usize = 15;
/// Index of the attitude error `δθ` (NED rotation vector, rad).
pub const ATT: usize = 0;
/// Index of the velocity error (m/s, NED).
pub const VEL: usize = 3;
/// Index of the position error (m, NED).
pub const POS: usize = 6;
/// Index of the gyro bias error (rad/s, body FRD).
pub const GYRO_BIAS: usize = 9;
/// Index of the accelerometer bias error (m/s², body FRD).
pub const ACCEL_BIAS: usize = 12;

/// Covariance of the error state.
pub type Covariance = SMatrix<f64, ERROR_STATES, ERROR_STATES>;
/// An error-state vector.
pub type ErrorVector = SVector<f64, ERROR_STATES>;

/// The nominal state at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State {
    /// When this state is valid (the time of the last IMU sample integrated).
    pub time: Time,
    /// Rotation from body FRD to NED.
    pub attitude: UnitQuaternion<f64>,
    /// Velocity north, east, down (m/s).
    pub vel_ned_m_s: Vector3<f64>,
    /// Position north, east, down from the origin (m).
    pub pos_ned_m: Vector3<f64>,
    /// Gyro bias, body FRD (rad/s).
    pub gyro_bias_rad_s: Vector3<f64>,
    /// Accelerometer bias, body FRD (m/s²).
    pub accel_bias_m_s2: Vector3<f64>,
}

impl State {
    /// At rest at the origin with attitude `attitude` and no bias.
    pub fn at_rest(time: Time, attitude: UnitQuaternion<f64>) -> State {
        State {
            time,
            attitude,
            vel_ned_m_s: Vector3::zeros(),
            pos_ned_m: Vector3::zeros(),
            gyro_bias_rad_s: Vector3::zeros(),
            accel_bias_m_s2: Vector3::zeros(),
        }
    }

    /// Injects an error-state correction: `x ⊞ δx`.
    pub fn boxplus(&self, dx: &ErrorVector) -> State {
        let rot = UnitQuaternion::from_scaled_axis(dx.fixed_rows::<3>(ATT).into_owned());
        State {
            time: self.time,
            attitude: rot * self.attitude,
            vel_ned_m_s: self.vel_ned_m_s + dx.fixed_rows::<3>(VEL),
            pos_ned_m: self.pos_ned_m + dx.fixed_rows::<3>(POS),
            gyro_bias_rad_s: self.gyro_bias_rad_s + dx.fixed_rows::<3>(GYRO_BIAS),
            accel_bias_m_s2: self.accel_bias_m_s2 + dx.fixed_rows::<3>(ACCEL_BIAS),
        }
    }

    /// The error that takes `other` to `self`: `self ⊟ other`.
    pub fn boxminus(&self, other: &State) -> ErrorVector {
        let mut dx = ErrorVector::zeros();
        dx.fixed_rows_mut::<3>(ATT).copy_from(&(self.attitude * other.attitude.inverse()).scaled_axis());
        dx.fixed_rows_mut::<3>(VEL).copy_from(&(self.vel_ned_m_s - other.vel_ned_m_s));
        dx.fixed_rows_mut::<3>(POS).copy_from(&(self.pos_ned_m - other.pos_ned_m));
        dx.fixed_rows_mut::<3>(GYRO_BIAS).copy_from(&(self.gyro_bias_rad_s - other.gyro_bias_rad_s));
        dx.fixed_rows_mut::<3>(ACCEL_BIAS).copy_from(&(self.accel_bias_m_s2 - other.accel_bias_m_s2));
        dx
    }

    /// Whether every element is finite.
    pub fn is_finite(&self) -> bool {
        self.attitude.coords.iter().all(|x| x.is_finite())
            && self.vel_ned_m_s.iter().all(|x| x.is_finite())
            && self.pos_ned_m.iter().all(|x| x.is_finite())
            && self.gyro_bias_rad_s.iter().all(|x| x.is_finite())
            && self.accel_bias_m_s2.iter().all(|x| x.is_finite())
    }
}

/// One IMU sample as increments over its interval, in body FRD.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuDelta {
    /// End of the interval (the sample's measurement time).
    pub time: Time,
    /// Integrated angular rate (rad).
    pub delta_angle_rad: Vector3<f64>,
    /// Integrated specific force (m/s).
    pub delta_velocity_m_s: Vector3<f64>,
    /// Length of the interval (s).
    pub dt_s: f64,
    /// An accelerometer axis read full scale: `delta_velocity_m_s` understates the interval.
    pub accel_clipped: bool,
}

impl ImuDelta {
    /// Increments from mean rates over `dt_s`.
    pub fn from_rates(time: Time, gyro_rad_s: [f64; 3], accel_m_s2: [f64; 3], dt_s: f64) -> ImuDelta {
        ImuDelta {
            time,
            delta_angle_rad: Vector3::from(gyro_rad_s) * dt_s,
            delta_velocity_m_s: Vector3::from(accel_m_s2) * dt_s,
            dt_s,
            accel_clipped: false,
        }
    }
}
