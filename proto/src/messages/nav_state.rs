use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::geo::Geodetic;
use crate::time::Time;

/// Which parts of a [`NavState`] may be flown on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct NavValidity {
    /// Roll, pitch and yaw have converged (tilt from the accelerometer, yaw from the compass).
    pub attitude: bool,
    /// North/east velocity is observed (GPS, or drag against the learnt wind, fused recently).
    pub horizontal_velocity: bool,
    /// The north/east velocity is drag's against the wind learnt before GPS was lost: good to
    /// hold still against the wind, not to tell standing from drifting on the ground, where the
    /// contact, not drag, holds the vehicle and drag would read the wind as its motion (so the
    /// land detectors leave it out).
    #[serde(default)]
    pub horizontal_velocity_from_drag: bool,
    /// North/east position is observed; false after GPS has been lost past its timeout.
    pub horizontal_position: bool,
    /// Down velocity is observed.
    pub vertical_velocity: bool,
    /// Height is observed (barometer or GPS).
    pub vertical_position: bool,
}

impl NavValidity {
    /// Everything observed.
    pub const ALL: NavValidity = NavValidity {
        attitude: true,
        horizontal_velocity: true,
        horizontal_velocity_from_drag: false,
        horizontal_position: true,
        vertical_velocity: true,
        vertical_position: true,
    };

    /// Whether the north/east velocity says how fast the vehicle moves over the ground however
    /// it is held: observed, and not drag's (see `horizontal_velocity_from_drag`). The land
    /// detectors test the horizontal speed only then.
    pub fn ground_speed_observed(&self) -> bool {
        self.horizontal_velocity && !self.horizontal_velocity_from_drag
    }
}

/// The estimator's best knowledge of the vehicle, published at IMU rate for the controllers.
///
/// This is the thesis's 16-element state (eq. 3.13): attitude quaternion, NED velocity, NED
/// position, gyro bias and accelerometer bias, carried to the present by the output predictor.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct NavState {
    /// The IMU sample time this state is valid at.
    pub time: Time,
    /// Attitude quaternion `[w, x, y, z]` rotating body FRD into NED.
    pub attitude: [f64; 4],
    /// Bias-corrected angular rate about body forward, right, down (rad/s).
    pub angular_velocity_rad_s: [f64; 3],
    /// Velocity north, east, down (m/s).
    pub velocity_ned_m_s: [f64; 3],
    /// Position north, east, down from `origin` (m).
    pub position_ned_m: [f64; 3],
    /// Estimated gyro bias, body FRD (rad/s).
    pub gyro_bias_rad_s: [f64; 3],
    /// Estimated accelerometer bias, body FRD (m/s²).
    pub accel_bias_m_s2: [f64; 3],
    /// Variances of the 16 states in the order above: quaternion w, x, y, z; velocity N, E, D;
    /// position N, E, D; gyro bias x, y, z; accel bias x, y, z (units squared).
    pub covariance_diagonal: [f64; 16],
    /// Where the local NED frame is anchored (the first good 3D GPS fix); `None` until then.
    pub origin: Option<Geodetic>,
    pub valid: NavValidity,
}
crate::impl_message!(NavState);

impl NavState {
    /// A state known exactly: true values with zero biases and covariance, every part valid and
    /// no geodetic origin. For feeding ground truth to the controllers in tests and benches.
    pub fn exact(
        time: Time,
        attitude: [f64; 4],
        angular_velocity_rad_s: [f64; 3],
        velocity_ned_m_s: [f64; 3],
        position_ned_m: [f64; 3],
    ) -> NavState {
        NavState {
            time,
            attitude,
            angular_velocity_rad_s,
            velocity_ned_m_s,
            position_ned_m,
            gyro_bias_rad_s: [0.0; 3],
            accel_bias_m_s2: [0.0; 3],
            covariance_diagonal: [0.0; 16],
            origin: None,
            valid: NavValidity::ALL,
        }
    }
}
