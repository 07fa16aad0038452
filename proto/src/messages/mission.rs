//! A waypoint mission, as uploaded by a ground station or loaded from a QGroundControl `.plan`.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// Most items a flight mission may hold, however it arrives: MAVLink upload (which refuses a
/// larger MISSION_COUNT with NO_SPACE), a `.plan` file, or the graph. 1000 is ArduPilot's
/// practical ceiling on a board with little storage and far beyond any survey a multirotor
/// battery can fly.
pub const MAX_MISSION_ITEMS: usize = 1000;

/// What a mission item's altitude is measured from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum AltitudeFrame {
    /// Above the home position (MAVLink `MAV_FRAME_GLOBAL_RELATIVE_ALT`).
    RelativeHome,
    /// Above mean sea level (MAVLink `MAV_FRAME_GLOBAL`).
    Amsl,
}

/// A point in WGS-84 with its altitude reference.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct MissionPoint {
    /// Latitude (degrees).
    pub lat_deg: f64,
    /// Longitude (degrees).
    pub lon_deg: f64,
    /// Altitude (m) in `frame`.
    pub alt_m: f64,
    pub frame: AltitudeFrame,
}

/// One step of a mission.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum MissionItem {
    /// Climb vertically to the item's altitude (its lat/lon are ignored when not finite).
    Takeoff { point: MissionPoint },
    /// Fly to the point; reached within `acceptance_radius_m` (3D); then wait `hold_s`.
    Waypoint { point: MissionPoint, acceptance_radius_m: f64, hold_s: f64 },
    /// Wait where the vehicle is for `duration_s` (s).
    LoiterTime { duration_s: f64 },
    /// Change the cruise speed (m/s) for the following legs.
    ChangeSpeed { speed_m_s: f64 },
    /// Fly to the point's horizontal position and land there.
    Land { point: MissionPoint },
    /// Return to launch and land.
    ReturnToLaunch,
}

/// A whole mission; replacing it restarts progress at item 0.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Mission {
    pub time: Time,
    pub items: Vec<MissionItem>,
    /// Cruise speed between waypoints (m/s) unless an item changes it.
    pub cruise_speed_m_s: f64,
}
crate::impl_message!(Mission);
