//! How high the vehicle flies above the ground under it, for `ground_match_height_m`
//! (`AVOID_GND_HGT`): above it the stereo pair cannot match the ground below the flight path, so
//! an invalid view ahead reads as open sky, not as a textureless wall.
//!
//! The sources, best first:
//! 1. the downward rangefinder, while it returns a distance no older than [`RANGE_FRESH_S`]: the
//!    slant range times the cosine of the tilt (the beam is along the body's z axis);
//! 2. the height above home (the commander's home, set where the vehicle armed): a vehicle that
//!    armed on a rooftop or a hillside measures from there, not from the estimator's origin,
//!    which may lie metres below (`tests` below: a rooftop take-off keeps the check on);
//! 3. without either, the height above the estimator's origin.
//!
//! Without terrain data the ground is taken as flat at home's height: ArduPilot's
//! `RNGFND_*`/terrain following does the same with no terrain database.

use kestrel_proto::Time;
use kestrel_proto::messages::{RangefinderOrientation, RangefinderSample};

/// A rangefinder reading older than this (s) is not used: at 100 Hz that is 30 missed samples.
pub const RANGE_FRESH_S: f64 = 0.3;

/// Where the height above the ground came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HeightSource {
    Rangefinder,
    Home,
    Origin,
}

/// The newest inputs to the height above the ground.
#[derive(Clone, Copy, Debug, Default)]
pub struct GroundHeight {
    /// Home's down coordinate in the estimator's frame (m), once the commander has one.
    home_down_m: Option<f64>,
    /// The newest usable downward reading: its time and distance along the beam (m).
    range: Option<(Time, f64)>,
    /// Cosine of the newest attitude's tilt (1 level).
    tilt_cos: Option<f64>,
}

impl GroundHeight {
    /// Home's NED position from the commander's status; `None` (no home yet) forgets it; a
    /// position that is not finite is ignored.
    pub fn set_home(&mut self, home_ned_m: Option<[f64; 3]>) {
        match home_ned_m {
            Some(ned) if ned.iter().all(|v| v.is_finite()) => self.home_down_m = Some(ned[2]),
            Some(_) => {}
            None => self.home_down_m = None,
        }
    }

    /// A rangefinder sample: only a downward one with a valid distance is kept; a reading of
    /// nothing within range, or a bad one, forgets the last, so the next source is used.
    pub fn set_range(&mut self, sample: &RangefinderSample) {
        if sample.orientation != RangefinderOrientation::Down {
            return;
        }
        self.range = match (sample.invalid(), sample.distance_m) {
            (None, Some(d)) => Some((sample.time, d)),
            _ => None,
        };
    }

    /// The attitude quaternion `[w, x, y, z]` (body FRD to NED) of the newest pose.
    pub fn set_attitude(&mut self, q: [f64; 4]) {
        let [_, x, y, _] = q;
        // The body z axis's NED down component: 1 − 2(x² + y²) for a unit quaternion.
        let cos = 1.0 - 2.0 * (x * x + y * y);
        self.tilt_cos = cos.is_finite().then_some(cos.clamp(0.0, 1.0));
    }

    /// The height above the ground (m) at `now` for a vehicle at `down_m` in the estimator's
    /// frame, and where it came from.
    pub fn above_ground_m(&self, now: Time, down_m: f64) -> (f64, HeightSource) {
        if let Some((time, d)) = self.range
            && now.saturating_since(time).as_secs_f64() <= RANGE_FRESH_S
        {
            return (d * self.tilt_cos.unwrap_or(1.0), HeightSource::Rangefinder);
        }
        match self.home_down_m {
            Some(home) => (home - down_m, HeightSource::Home),
            None => (-down_m, HeightSource::Origin),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn down(t_s: f64, distance_m: Option<f64>) -> RangefinderSample {
        RangefinderSample {
            time: Time::from_secs_f64(t_s),
            orientation: RangefinderOrientation::Down,
            distance_m,
            min_range_m: 0.1,
            max_range_m: 12.0,
        }
    }

    #[test]
    fn a_rooftop_take_off_measures_from_home_not_from_the_origin() {
        // Armed on a roof 10 m above the estimator's origin, flying 6 m above the roof.
        let mut height = GroundHeight::default();
        assert_eq!(height.above_ground_m(Time::ZERO, -16.0), (16.0, HeightSource::Origin));
        height.set_home(Some([0.0, 0.0, -10.0]));
        assert_eq!(height.above_ground_m(Time::ZERO, -16.0), (6.0, HeightSource::Home));
        height.set_home(Some([f64::NAN, 0.0, 0.0]));
        assert_eq!(height.above_ground_m(Time::ZERO, -16.0).0, 6.0, "a bad home is ignored");
    }

    #[test]
    fn a_fresh_downward_reading_wins_tilted_and_a_stale_or_empty_one_does_not() {
        let mut height = GroundHeight::default();
        height.set_home(Some([0.0; 3]));
        height.set_range(&down(1.0, Some(4.0)));
        let now = Time::from_secs_f64(1.1);
        assert_eq!(height.above_ground_m(now, -16.0), (4.0, HeightSource::Rangefinder));
        // 60° of roll: half the slant range.
        let half = std::f64::consts::FRAC_PI_6; // half of 60°
        height.set_attitude([half.cos(), half.sin(), 0.0, 0.0]);
        let (h, _) = height.above_ground_m(now, -16.0);
        assert!((h - 2.0).abs() < 1e-9, "{h}");
        assert_eq!(height.above_ground_m(Time::from_secs_f64(1.4), -16.0).1, HeightSource::Home, "stale");
        height.set_range(&down(1.5, None));
        assert_eq!(height.above_ground_m(Time::from_secs_f64(1.5), -16.0), (16.0, HeightSource::Home));
        height.set_range(&down(1.6, Some(-1.0)));
        assert_eq!(height.above_ground_m(Time::from_secs_f64(1.6), -16.0).1, HeightSource::Home, "invalid");
        let up = RangefinderSample { orientation: RangefinderOrientation::Up, ..down(1.7, Some(1.0)) };
        height.set_range(&up);
        assert_eq!(height.above_ground_m(Time::from_secs_f64(1.7), -16.0).1, HeightSource::Home, "upward");
    }
}
