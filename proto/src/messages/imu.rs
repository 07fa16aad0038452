use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// One inertial sample: angular rate and specific force in the body FRD frame.
///
/// Specific force is what an accelerometer measures: a vehicle at rest reads about
/// `[0, 0, -9.81]` (the ground pushes it up, along −down).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ImuSample {
    /// Measurement time.
    pub time: Time,
    /// Angular rate about body forward, right, down (rad/s).
    pub gyro_rad_s: [f64; 3],
    /// Specific force along body forward, right, down (m/s²).
    pub accel_m_s2: [f64; 3],
    /// Interval this sample integrates over (s); the estimator's prediction step.
    pub dt_s: f64,
    /// Per body axis (forward, right, down): some gyro reading behind this sample was at the
    /// sensor's full scale, so the true rate may be larger than `gyro_rad_s` says. Absent in
    /// logs written before the flag existed, which then read as unclipped.
    #[serde(default)]
    pub gyro_clipped: [bool; 3],
    /// Per body axis: some accelerometer reading behind this sample was at full scale (PX4's
    /// EKF2 distrusts such an axis; our estimator counts them and warns).
    #[serde(default)]
    pub accel_clipped: [bool; 3],
}
crate::impl_message!(ImuSample);

impl ImuSample {
    /// Whether any axis of either sensor was clipped.
    pub fn is_clipped(&self) -> bool {
        self.gyro_clipped.iter().chain(&self.accel_clipped).any(|&c| c)
    }
}
