//! The land detector: while a landing is commanded, the vehicle has landed once it has stopped
//! moving vertically and horizontally for a while (it is asked to descend, so standing still
//! means the ground holds it). PX4's detector also watches thrust; the commander does not see
//! the thrust, and a commanded descent that does not happen is as telling.

use kestrel_proto::Time;

/// Vertical speed below which the vehicle counts as not descending (m/s).
const STILL_VERTICAL_M_S: f64 = 0.2;
/// Horizontal speed below which the vehicle counts as not drifting (m/s).
const STILL_HORIZONTAL_M_S: f64 = 0.5;

#[derive(Clone, Debug, Default)]
pub struct LandDetector {
    still_since: Option<Time>,
}

impl LandDetector {
    /// Forgets the history (a new landing).
    pub fn reset(&mut self) {
        self.still_since = None;
    }

    /// True once still for `detect_s` while landing, given the NED velocity (m/s).
    pub fn update(&mut self, now: Time, velocity_ned_m_s: &[f64; 3], detect_s: f64) -> bool {
        let [n, e, d] = *velocity_ned_m_s;
        let still = d.abs() < STILL_VERTICAL_M_S && n.hypot(e) < STILL_HORIZONTAL_M_S;
        if !still {
            self.still_since = None;
            return false;
        }
        let since = *self.still_since.get_or_insert(now);
        now.saturating_since(since).as_secs_f64() >= detect_s
    }
}
