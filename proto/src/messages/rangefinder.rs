use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// Which way a single-beam rangefinder looks, along the body's z axis (FRD), as MAVLink's
/// `DISTANCE_SENSOR.orientation` names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum RangefinderOrientation {
    /// Out of the top (−z): what is overhead (`MAV_SENSOR_ROTATION_PITCH_90`, 24).
    Up,
    /// Out of the bottom (+z): the ground or whatever stands under the vehicle
    /// (`MAV_SENSOR_ROTATION_PITCH_270`, 25).
    Down,
}

impl RangefinderOrientation {
    /// MAVLink's `MAV_SENSOR_ORIENTATION` value.
    pub fn mavlink_rotation(self) -> u8 {
        match self {
            RangefinderOrientation::Up => 24,
            RangefinderOrientation::Down => 25,
        }
    }

    /// The beam's direction in the body frame (FRD), a unit vector.
    pub fn body_axis(self) -> [f64; 3] {
        match self {
            RangefinderOrientation::Up => [0.0, 0.0, -1.0],
            RangefinderOrientation::Down => [0.0, 0.0, 1.0],
        }
    }
}

/// One reading of a single-beam rangefinder fixed to the airframe (a Benewake TFmini, a
/// Garmin LIDAR-Lite, a VL53L1X): the distance along its beam to the first surface.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct RangefinderSample {
    /// Measurement time.
    pub time: Time,
    pub orientation: RangefinderOrientation,
    /// Distance along the beam to the surface (m); `None` when nothing returned within
    /// `max_range_m` (open sky, or ground out of reach), as the sensor reports its maximum.
    pub distance_m: Option<f64>,
    /// The sensor's shortest reliable distance (m): nearer surfaces read as this or not at all.
    pub min_range_m: f64,
    /// The sensor's longest distance (m).
    pub max_range_m: f64,
}
crate::impl_message!(RangefinderSample);

impl RangefinderSample {
    /// Why the sample cannot be used, if it cannot: ranges that are not finite, not increasing
    /// or negative, or a distance outside them. A bad reading is refused, never clamped.
    pub fn invalid(&self) -> Option<String> {
        let (min, max) = (self.min_range_m, self.max_range_m);
        if !(min.is_finite() && max.is_finite() && 0.0 <= min && min < max) {
            return Some(format!("range {min}..{max} m must be finite, non-negative and increasing"));
        }
        match self.distance_m {
            Some(d) if !(min..=max).contains(&d) => {
                Some(format!("distance {d} m lies outside the sensor's {min}..{max} m"))
            }
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(distance_m: Option<f64>) -> RangefinderSample {
        RangefinderSample {
            time: Time(0),
            orientation: RangefinderOrientation::Down,
            distance_m,
            min_range_m: 0.1,
            max_range_m: 12.0,
        }
    }

    #[test]
    fn distances_outside_the_range_and_non_finite_values_are_refused() {
        assert_eq!(sample(Some(3.0)).invalid(), None);
        assert_eq!(sample(None).invalid(), None);
        for d in [f64::NAN, f64::INFINITY, -1.0, 0.05, 12.5] {
            assert!(sample(Some(d)).invalid().is_some(), "{d}");
        }
        for (min, max) in [(f64::NAN, 12.0), (0.1, f64::INFINITY), (-0.1, 12.0), (12.0, 12.0)] {
            let s = RangefinderSample { min_range_m: min, max_range_m: max, ..sample(None) };
            assert!(s.invalid().is_some(), "{min} {max}");
        }
    }

    #[test]
    fn orientations_are_mavlinks_and_point_along_body_z() {
        assert_eq!(RangefinderOrientation::Up.mavlink_rotation(), 24);
        assert_eq!(RangefinderOrientation::Down.mavlink_rotation(), 25);
        assert_eq!(RangefinderOrientation::Down.body_axis(), [0.0, 0.0, 1.0]);
    }
}
