use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// Fix quality as receivers report it (u-blox NAV-PVT `fixType`, MAVLink `GPS_FIX_TYPE`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum GpsFixType {
    NoFix,
    Fix2d,
    Fix3d,
    Dgps,
    RtkFloat,
    RtkFixed,
}

/// A GNSS position and velocity solution.
///
/// `time` is when the solution is *valid* (the receiver's time of validity mapped onto the
/// graph clock), which is earlier than when it arrives: receivers lag by 100–250 ms and the
/// estimator fuses the fix against its state at `time`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct GpsFix {
    /// Time of validity.
    pub time: Time,
    pub fix_type: GpsFixType,
    pub satellites: u8,
    /// WGS-84 latitude (degrees, north positive).
    pub lat_deg: f64,
    /// WGS-84 longitude (degrees, east positive).
    pub lon_deg: f64,
    /// Altitude above mean sea level (m).
    pub alt_msl_m: f64,
    /// Velocity north, east, down (m/s).
    pub vel_ned_m_s: [f64; 3],
    /// 1σ horizontal position accuracy (m).
    pub h_acc_m: f64,
    /// 1σ vertical position accuracy (m).
    pub v_acc_m: f64,
    /// 1σ speed accuracy (m/s).
    pub s_acc_m_s: f64,
}
crate::impl_message!(GpsFix);
