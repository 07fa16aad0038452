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

/// A whole mission. A new one replaces the old: on the ground its run starts at item 0; one
/// uploaded while the old is flown in AUTO is flown from the same item index.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Mission {
    pub time: Time,
    pub items: Vec<MissionItem>,
    /// Cruise speed between waypoints (m/s) unless an item changes it.
    pub cruise_speed_m_s: f64,
}
crate::impl_message!(Mission);

impl Mission {
    /// What can be checked without knowing where the vehicle is: the item count and that every
    /// number is one and in range. The one check for missions however they arrive: the link
    /// runs it before it acknowledges an upload (so the commander never refuses what was
    /// ACKed), the commander on a `.plan` file and on every mission it is given. The text names
    /// the item (counted from 1, home not being one) and what is wrong.
    pub fn check_fields(&self) -> Result<(), String> {
        let n = self.items.len();
        if n == 0 {
            return Err("mission refused: no items".into());
        }
        if n > MAX_MISSION_ITEMS {
            return Err(format!("mission refused: {n} items, at most {MAX_MISSION_ITEMS}"));
        }
        if !(self.cruise_speed_m_s.is_finite() && self.cruise_speed_m_s > 0.0) {
            return Err(format!("mission refused: cruise speed {} m/s", self.cruise_speed_m_s));
        }
        for (i, item) in self.items.iter().enumerate() {
            let bad = |what: &str| Err(format!("mission item {}: {what}", i + 1));
            let finite_point = |p: &MissionPoint| p.lat_deg.is_finite() && p.lon_deg.is_finite();
            match *item {
                MissionItem::Takeoff { point } if !point.alt_m.is_finite() => {
                    return bad("altitude is not a number");
                }
                MissionItem::Waypoint { point, .. } | MissionItem::Land { point }
                    if !finite_point(&point) =>
                {
                    return bad("latitude/longitude is not a number");
                }
                MissionItem::Waypoint { point, .. } if !point.alt_m.is_finite() => {
                    return bad("altitude is not a number");
                }
                MissionItem::Waypoint { acceptance_radius_m, hold_s, .. }
                    if !(acceptance_radius_m.is_finite()
                        && acceptance_radius_m > 0.0
                        && hold_s.is_finite()
                        && hold_s >= 0.0) =>
                {
                    return bad("acceptance radius or hold time out of range");
                }
                MissionItem::LoiterTime { duration_s } if !(duration_s.is_finite() && duration_s >= 0.0) => {
                    return bad("loiter time out of range");
                }
                MissionItem::ChangeSpeed { speed_m_s } if !(speed_m_s.is_finite() && speed_m_s > 0.0) => {
                    return bad("speed out of range");
                }
                _ => {}
            }
            if let MissionItem::Takeoff { point }
            | MissionItem::Waypoint { point, .. }
            | MissionItem::Land { point } = item
                && finite_point(point)
                && !(point.lat_deg.abs() <= 90.0 && point.lon_deg.abs() <= 180.0)
            {
                return bad("latitude/longitude out of range");
            }
        }
        Ok(())
    }
}
