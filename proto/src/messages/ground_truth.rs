use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// The simulator's true vehicle state, for scoring estimators and controllers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct GroundTruth {
    pub time: Time,
    /// Position north, east, down from home (m).
    pub position_ned_m: [f64; 3],
    /// Velocity north, east, down (m/s).
    pub velocity_ned_m_s: [f64; 3],
    /// Acceleration north, east, down (m/s²).
    pub acceleration_ned_m_s2: [f64; 3],
    /// Attitude quaternion `[w, x, y, z]` rotating body FRD into NED.
    pub attitude: [f64; 4],
    /// Angular rate about body forward, right, down (rad/s).
    pub angular_velocity_rad_s: [f64; 3],
    /// WGS-84 latitude (degrees).
    pub lat_deg: f64,
    /// WGS-84 longitude (degrees).
    pub lon_deg: f64,
    /// Altitude above mean sea level (m).
    pub alt_msl_m: f64,
    /// True when the vehicle rests on the ground.
    pub landed: bool,
    /// True once the vehicle has tipped over or hit the ground too hard.
    pub crashed: bool,
    /// Collisions with world obstacles so far.
    pub collisions: u32,
    /// Distance from the vehicle's centre to the nearest obstacle surface (m); `None` in a
    /// world without obstacles (JSON has no infinity).
    pub clearance_m: Option<f64>,
}
crate::impl_message!(GroundTruth);

impl Default for GroundTruth {
    /// At rest at the origin, level and facing north (the identity attitude, not a zero
    /// quaternion), on no particular spot of the Earth: for tests that set what they need.
    fn default() -> GroundTruth {
        GroundTruth {
            time: Time::ZERO,
            position_ned_m: [0.0; 3],
            velocity_ned_m_s: [0.0; 3],
            acceleration_ned_m_s2: [0.0; 3],
            attitude: [1.0, 0.0, 0.0, 0.0],
            angular_velocity_rad_s: [0.0; 3],
            lat_deg: 0.0,
            lon_deg: 0.0,
            alt_msl_m: 0.0,
            landed: false,
            crashed: false,
            collisions: 0,
            clearance_m: None,
        }
    }
}
