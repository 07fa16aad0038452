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
}
crate::impl_message!(ImuSample);
