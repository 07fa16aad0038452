//! `[actors.NAME.params]` of a `proximity` actor: how long and how far the obstacle memory
//! behind the full-surround sectors keeps what the camera saw. The defaults are the avoider's
//! (`AvoiderParams`), which its forest flights tuned.

use serde::Deserialize;

use crate::ParamsError;
use crate::avoidance::memory::MemorySettings;

/// Parameters of the full-surround sectors.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ProximityParams {
    /// A remembered point is forgotten this long after it was last seen or last near the
    /// vehicle (s); 0 turns the memory off (the sectors are then the camera's alone).
    pub memory_time_s: f64,
    /// Sector ranges up to this are remembered; farther points are forgotten (m). ArduPilot's
    /// BendyRuler looks `OA_BR_LOOKAHEAD` (15 m by default) ahead, its simple avoidance
    /// `AVOID_MARGIN` (2 m) plus a braking distance: 10 m covers the second.
    pub memory_range_m: f64,
    /// Points seen from more than this above or below the vehicle's height are left out (m).
    pub memory_height_m: f64,
    /// Points within this horizontal distance of the vehicle do not age (m).
    pub keep_within_m: f64,
    /// A grid older than this when it arrives is refused (s): its sectors describe where the
    /// vehicle was. ArduPilot drops proximity data 0.5 s after the last message
    /// (`AP_Proximity_MAV`), so nothing older is worth sending.
    pub max_grid_age_s: f64,
}

impl Default for ProximityParams {
    fn default() -> ProximityParams {
        ProximityParams {
            memory_time_s: 30.0,
            memory_range_m: 10.0,
            memory_height_m: 1.5,
            keep_within_m: 4.0,
            max_grid_age_s: 0.5,
        }
    }
}

impl ProximityParams {
    /// Checks every value, naming the first bad one.
    pub fn validate(&self) -> Result<(), ParamsError> {
        let positive = [
            ("memory_range_m", self.memory_range_m),
            ("memory_height_m", self.memory_height_m),
            ("max_grid_age_s", self.max_grid_age_s),
        ];
        for (field, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(ParamsError { field, value, expected: "a finite value > 0" });
            }
        }
        let non_negative = [("memory_time_s", self.memory_time_s), ("keep_within_m", self.keep_within_m)];
        for (field, value) in non_negative {
            if !(value.is_finite() && value >= 0.0) {
                return Err(ParamsError { field, value, expected: "a finite value ≥ 0" });
            }
        }
        Ok(())
    }

    /// The memory's settings, `None` when it is off.
    pub fn memory_settings(&self) -> Option<MemorySettings> {
        (self.memory_time_s > 0.0).then_some(MemorySettings {
            time_s: self.memory_time_s,
            range_m: self.memory_range_m,
            height_m: self.memory_height_m,
            keep_within_m: self.keep_within_m,
            unmeasured_clear_m: 0.0,
        })
    }
}
