//! The navigation state the commander flies on: the estimator's, or the controller's backup
//! attitude's while the estimator's is stale, and how long the estimator has been stale.
//!
//! The backup carries an attitude, a height and a climb rate (no horizontal position), so that
//! the modes, the landing and the land detector keep working; the estimator's own freshness
//! stays a failsafe (`NavStateStale`, net of its returns: `failsafe.nav_stale_s`). A restarted
//! estimator is flown on again once its attitude is valid.

use kestrel_proto::Time;
use kestrel_proto::attitude::unit_quaternion;
use kestrel_proto::messages::NavState;

use super::failsafe::NetHeldFor;

/// The state flown on and the estimator's health.
#[derive(Debug, Default)]
pub(crate) struct NavSource {
    /// The state flown on: the estimator's, or the backup attitude's while `on_backup`.
    latest: Option<NavState>,
    /// Time of the estimator's newest state: its staleness is a failsafe whatever the backup
    /// does.
    estimator_at: Option<Time>,
    /// The estimator's newest state had a valid attitude.
    estimator_attitude_valid: bool,
    /// `latest` is the backup attitude's.
    on_backup: bool,
    /// How long the estimator's state has been stale while armed, net of its returns.
    stale: NetHeldFor,
}

impl NavSource {
    /// The state flown on, however old.
    pub fn latest(&self) -> Option<&NavState> {
        self.latest.as_ref()
    }

    /// The state flown on if it is no older than `timeout_s` at `now`.
    pub fn fresh(&self, now: Time, timeout_s: f64) -> Option<&NavState> {
        self.latest.as_ref().filter(|n| now.saturating_since(n.time).as_secs_f64() <= timeout_s)
    }

    /// The estimator's newest state is no older than `timeout_s` at `now`.
    pub fn estimator_fresh(&self, now: Time, timeout_s: f64) -> bool {
        self.estimator_at.is_some_and(|t| now.saturating_since(t).as_secs_f64() <= timeout_s)
    }

    /// The state flown on is the backup attitude's.
    pub fn backup_flown(&self) -> bool {
        self.on_backup
    }

    /// A state of the estimator: whether to fly on it (a usable one, unless the backup flies
    /// and the estimator is still aligning).
    pub fn on_estimator(&mut self, nav: &NavState) -> bool {
        if !usable(nav) {
            return false;
        }
        self.estimator_at = Some(nav.time);
        self.estimator_attitude_valid = nav.valid.attitude;
        if !nav.valid.attitude && self.on_backup {
            // A restarted estimator still aligning: the backup flies on.
            return false;
        }
        if self.on_backup {
            tracing::warn!(at = %nav.time, "estimator back: flying on its state again");
            self.on_backup = false;
        }
        true
    }

    /// A state of the backup attitude: `None` when it is not flown on (unusable, or the
    /// estimator is fresh with a valid attitude at its time, `timeout_s` old at most),
    /// otherwise whether the backup takes over now.
    pub fn on_backup(&mut self, nav: &NavState, timeout_s: f64) -> Option<bool> {
        if !usable(nav) || (self.estimator_fresh(nav.time, timeout_s) && self.estimator_attitude_valid) {
            return None;
        }
        let switched = !self.on_backup;
        if switched {
            tracing::error!(at = %nav.time, "estimator failed: flying on the backup attitude");
            self.on_backup = true;
        }
        Some(switched)
    }

    /// Flies on `nav` from now on.
    pub fn take(&mut self, nav: &NavState) {
        self.latest = Some(nav.clone());
    }

    /// Whether the estimator, not `fresh`, has been stale for `for_s` while armed, net of its
    /// returns; disarmed, the time held is forgotten.
    pub fn stale_for(&mut self, now: Time, armed: bool, fresh: bool, for_s: f64) -> bool {
        if !armed {
            self.stale.reset();
        }
        self.stale.check(now, armed && !fresh, for_s)
    }
}

/// A state `on_nav` keeps: finite, and its attitude a rotation (the loop rejects others too).
fn usable(nav: &NavState) -> bool {
    nav.position_ned_m.iter().chain(&nav.velocity_ned_m_s).all(|v| v.is_finite())
        && unit_quaternion(nav.attitude).is_ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commander::tests::nav;

    fn at(t_s: f64, attitude_valid: bool) -> NavState {
        let mut n = nav(Time::from_secs_f64(t_s), -5.0, true);
        n.valid.attitude = attitude_valid;
        n
    }

    #[test]
    fn non_finite_states_and_attitudes_that_are_no_rotation_are_not_flown() {
        let mut s = NavSource::default();
        let mut n = at(1.0, true);
        n.position_ned_m[0] = f64::NAN;
        assert!(!s.on_estimator(&n));
        let mut n = at(1.0, true);
        n.attitude = [0.0; 4];
        assert!(!s.on_estimator(&n));
        assert_eq!(s.on_backup(&n, 0.5), None);
        assert!(!s.estimator_fresh(Time::from_secs_f64(1.0), 0.5), "not counted as the estimator's");
    }

    #[test]
    fn the_backup_flies_while_the_estimator_is_stale_until_it_is_back_and_aligned() {
        let mut s = NavSource::default();
        assert!(s.on_estimator(&at(1.0, true)));
        assert_eq!(s.on_backup(&at(1.2, true), 0.5), None, "the estimator is fresh");
        assert_eq!(s.on_backup(&at(2.0, true), 0.5), Some(true), "stale: the backup takes over");
        assert_eq!(s.on_backup(&at(2.1, true), 0.5), Some(false), "and flies on");
        assert!(s.backup_flown());
        assert!(!s.on_estimator(&at(2.2, false)), "a restarted estimator still aligning");
        assert!(s.backup_flown());
        assert!(s.on_estimator(&at(2.3, true)));
        assert!(!s.backup_flown());
    }

    #[test]
    fn staleness_counts_only_while_armed_and_is_forgotten_on_disarm() {
        let mut s = NavSource::default();
        let t = Time::from_secs_f64;
        assert!(!s.stale_for(t(1.0), true, false, 1.0));
        assert!(s.stale_for(t(2.5), true, false, 1.0));
        assert!(!s.stale_for(t(3.0), false, false, 1.0), "disarmed");
        assert!(!s.stale_for(t(3.5), true, false, 1.0), "counted afresh");
    }

    #[test]
    fn fresh_is_the_latest_state_within_the_timeout() {
        let mut s = NavSource::default();
        s.take(&at(1.0, true));
        assert!(s.fresh(Time::from_secs_f64(1.5), 0.5).is_some());
        assert!(s.fresh(Time::from_secs_f64(1.6), 0.5).is_none());
        assert!(s.latest().is_some());
    }
}
