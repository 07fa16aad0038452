//! Where another system says it is, for FOLLOW to fly after: MAVLink FOLLOW_TARGET, or the
//! GLOBAL_POSITION_INT every vehicle sends, from a system other than this one. The link decodes
//! and checks the fields; which system is followed, for how long a report counts and where
//! the vehicle flies relative to it are the commander's (`FOLL_*`, as ArduPilot's `AP_Follow`).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Which message a report came from: ArduPilot's `AP_Follow` prefers FOLLOW_TARGET and ignores
/// a system's GLOBAL_POSITION_INT while its FOLLOW_TARGETs keep coming.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum FollowSource {
    FollowTarget,
    GlobalPositionInt,
}

/// One position report of a system that may be followed, stamped by the link when it arrived
/// (the sender's own clock is not ours). Every field is finite and on the globe.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct FollowTarget {
    /// The sender's MAVLink system id.
    pub system_id: u8,
    pub source: FollowSource,
    /// WGS-84 latitude and longitude (deg).
    pub lat_deg: f64,
    pub lon_deg: f64,
    /// Altitude above mean sea level (m).
    pub alt_amsl_m: f64,
    /// Altitude above the sender's home (m): GLOBAL_POSITION_INT's `relative_alt`, what
    /// `FOLL_ALT_TYPE` 1 follows; `None` from FOLLOW_TARGET, which has none.
    pub alt_above_home_m: Option<f64>,
    /// NED velocity (m/s); zero when the sender does not report one.
    pub velocity_ned_m_s: [f64; 3],
    /// NED acceleration (m/s²); zero when the sender does not report one.
    pub acceleration_ned_m_s2: [f64; 3],
    /// Heading (rad, from north, clockwise), when the sender reports one.
    pub heading_rad: Option<f64>,
    /// Heading rate (rad/s, clockwise seen from above); zero when unknown.
    pub heading_rate_rad_s: f64,
}
