//! The land detector: while a landing is commanded, the vehicle has landed once it has stopped
//! moving vertically and horizontally for a while (it is asked to descend, so standing still
//! means the ground holds it). PX4's detector also watches thrust; the commander does not see
//! the thrust, and a commanded descent that does not happen is as telling.

use kestrel_proto::Time;

/// Vertical speed below which the vehicle counts as not descending (m/s).
const STILL_VERTICAL_M_S: f64 = 0.2;
/// Horizontal speed below which the vehicle counts as not drifting (m/s).
const STILL_HORIZONTAL_M_S: f64 = 0.5;
/// Height change over the detection time beyond which the vehicle is still descending (m): a
/// slow descent whose estimated speed dips under [`STILL_VERTICAL_M_S`] (0.25 m/s with noise,
/// a vehicle short of thrust) still loses more than this in a second, the ground holds it to
/// within the estimate's noise.
const STILL_HEIGHT_M: f64 = 0.15;

#[derive(Clone, Debug, Default)]
pub struct LandDetector {
    /// When the vehicle last began to look still, and its height down then (m).
    still_since: Option<(Time, f64)>,
}

impl LandDetector {
    /// Forgets the history (a new landing).
    pub fn reset(&mut self) {
        self.still_since = None;
    }

    /// True once still for `detect_s` while landing, given the NED velocity (m/s) and the height
    /// down (m): slow vertically, and not lower by more than [`STILL_HEIGHT_M`] than when it
    /// began to look so. Without an observed horizontal velocity (`horizontal_valid` false: GPS
    /// lost, dead reckoning) the estimate's north/east drift is the filter's, not the vehicle's,
    /// and only the vertical counts: a landing without position must still end (PX4's detector,
    /// too, tests the horizontal speed only when it is valid).
    pub fn update(
        &mut self,
        now: Time,
        velocity_ned_m_s: &[f64; 3],
        down_m: f64,
        horizontal_valid: bool,
        detect_s: f64,
    ) -> bool {
        let [n, e, d] = *velocity_ned_m_s;
        let still = d.abs() < STILL_VERTICAL_M_S && (!horizontal_valid || n.hypot(e) < STILL_HORIZONTAL_M_S);
        let sinking = self.still_since.is_some_and(|(_, start)| down_m - start > STILL_HEIGHT_M);
        if !still || sinking {
            self.still_since = None;
            return false;
        }
        let (since, _) = *self.still_since.get_or_insert((now, down_m));
        now.saturating_since(since).as_secs_f64() >= detect_s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(s: f64) -> Time {
        Time::from_micros((s * 1e6) as u64)
    }

    #[test]
    fn still_for_the_detection_time_is_landed_and_drifting_is_not() {
        let mut d = LandDetector::default();
        assert!(!d.update(at(0.0), &[0.0, 0.0, 0.05], 0.0, true, 1.0));
        assert!(d.update(at(1.0), &[0.1, 0.0, 0.05], 0.02, true, 1.0));
        d.reset();
        assert!(!d.update(at(2.0), &[0.8, 0.0, 0.0], 0.0, true, 1.0));
        assert!(!d.update(at(3.5), &[0.8, 0.0, 0.0], 0.0, true, 1.0), "drifting 0.8 m/s");
    }

    #[test]
    fn without_a_valid_horizontal_velocity_only_the_vertical_counts() {
        let mut d = LandDetector::default();
        assert!(!d.update(at(0.0), &[3.0, -2.0, 0.05], 0.0, false, 1.0));
        assert!(
            d.update(at(1.0), &[3.5, -2.5, 0.05], 0.0, false, 1.0),
            "the estimate drifts, the vehicle stands"
        );
        d.reset();
        assert!(!d.update(at(2.0), &[3.0, -2.0, 0.6], 0.0, false, 1.0));
        assert!(!d.update(at(3.5), &[3.0, -2.0, 0.6], 0.0, false, 1.0), "still descending");
    }

    #[test]
    fn a_slow_descent_whose_speed_dips_under_the_threshold_is_not_landed() {
        // 0.25 m/s down, estimated at 0.15-0.19 m/s: 2.3 m up, it must not be called landed.
        let mut d = LandDetector::default();
        let mut down = -2.3;
        for i in 0..=40 {
            let t = f64::from(i) * 0.05;
            down += 0.25 * 0.05;
            assert!(!d.update(at(t), &[0.0, 0.0, 0.17], down, true, 1.0), "landed at {t} s, {down:.2} m");
        }
    }
}
