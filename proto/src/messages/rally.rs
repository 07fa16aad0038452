//! Rally points: places other than home where RTL may return and land, as uploaded by a ground
//! station (MAVLink MISSION_TYPE_RALLY, ArduPilot's AP_Rally).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::mission::MissionPoint;
use crate::time::Time;

/// Most rally points a vehicle holds (ArduPilot's storage holds a few dozen; a ground station's
/// rally editor places a handful).
pub const MAX_RALLY_POINTS: usize = 100;

/// Every rally point the vehicle holds; a new message replaces them all, an empty one clears
/// them. Each point's altitude is above home (MAVLink `MAV_FRAME_GLOBAL_RELATIVE_ALT`, the one
/// frame ArduPilot accepts for a rally point).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct RallyPoints {
    pub time: Time,
    pub points: Vec<MissionPoint>,
}
crate::impl_message!(RallyPoints);

impl RallyPoints {
    /// Every number a rally point carries is one and on the globe, and there are at most
    /// [`MAX_RALLY_POINTS`]; the text names the point (counted from 0, as the ground station's
    /// item number) and what is wrong.
    pub fn check_fields(&self) -> Result<(), String> {
        if self.points.len() > MAX_RALLY_POINTS {
            return Err(format!("rally refused: {} points, at most {MAX_RALLY_POINTS}", self.points.len()));
        }
        for (i, p) in self.points.iter().enumerate() {
            if !(p.lat_deg.is_finite() && p.lat_deg.abs() <= 90.0) {
                return Err(format!("rally point {i}: latitude {} out of range", p.lat_deg));
            }
            if !(p.lon_deg.is_finite() && p.lon_deg.abs() <= 180.0) {
                return Err(format!("rally point {i}: longitude {} out of range", p.lon_deg));
            }
            if !p.alt_m.is_finite() {
                return Err(format!("rally point {i}: altitude is not a number"));
            }
        }
        Ok(())
    }
}
