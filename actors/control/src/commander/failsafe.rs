//! Failsafe bookkeeping: which causes are active, which action wins (PX4's precedence
//! warn < hold < RTL < land < disarm), and a log of every time one fired, for the report.

use kestrel_proto::Time;
use kestrel_proto::messages::{Failsafe, FailsafeAction, FailsafeCause};

const CAUSES: [FailsafeCause; 10] = [
    FailsafeCause::DataLinkLost,
    FailsafeCause::BatteryLow,
    FailsafeCause::BatteryCritical,
    FailsafeCause::GeofenceBreach,
    FailsafeCause::EstimatorUnhealthy,
    FailsafeCause::NavStateStale,
    FailsafeCause::CriticalActorFailed,
    FailsafeCause::ManualControlLost,
    FailsafeCause::MotorFailure,
    FailsafeCause::AvoidanceLost,
];

/// Causes that stay active once fired, for the rest of the flight: a battery does not
/// recharge, a motor that stopped is not trusted again, nor is obstacle data that was gone for
/// `avoidance_lost_s`, and an estimator or flight-critical actor that failed is not trusted again until
/// the flight ends (the landing it started must not be undone by the mode change it caused).
/// Every cause is cleared on disarm, as PX4 does; the pre-arm checks judge the next flight.
fn latches(cause: FailsafeCause) -> bool {
    matches!(
        cause,
        FailsafeCause::BatteryLow
            | FailsafeCause::BatteryCritical
            | FailsafeCause::CriticalActorFailed
            | FailsafeCause::EstimatorUnhealthy
            | FailsafeCause::MotorFailure
            | FailsafeCause::AvoidanceLost
    )
}

/// A condition that counts only once it has held for a while (a battery voltage under its
/// threshold for `BATT_LOW_TIMER`): true from the first check at least `for_s` after it began,
/// reset the moment it stops.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HeldFor {
    since: Option<Time>,
}

impl HeldFor {
    /// Whether `condition`, true now, has been true since at least `for_s` seconds ago.
    pub fn check(&mut self, now: Time, condition: bool, for_s: f64) -> bool {
        if !condition {
            self.since = None;
            return false;
        }
        let since = *self.since.get_or_insert(now);
        now.saturating_since(since).as_secs_f64() >= for_s
    }
}

fn slot(cause: FailsafeCause) -> usize {
    CAUSES.iter().position(|c| *c == cause).unwrap_or(0)
}

/// One failsafe firing, for logs and the run report.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FailsafeRecord {
    pub time: Time,
    pub cause: FailsafeCause,
    pub action: FailsafeAction,
}

/// The active failsafes.
#[derive(Clone, Debug, Default)]
pub struct FailsafeMonitor {
    active: [Option<Failsafe>; CAUSES.len()],
    log: Vec<FailsafeRecord>,
}

impl FailsafeMonitor {
    /// Updates one cause: `condition` true makes it active (logged on the rising edge), false
    /// clears it unless it latches.
    pub fn set(&mut self, now: Time, cause: FailsafeCause, condition: bool, action: FailsafeAction) {
        let entry = &mut self.active[slot(cause)];
        match (condition, entry.is_some()) {
            (true, false) => {
                *entry = Some(Failsafe { cause, action, since: now });
                self.log.push(FailsafeRecord { time: now, cause, action });
                tracing::warn!(?cause, ?action, "failsafe");
            }
            (false, true) if !latches(cause) => *entry = None,
            _ => {}
        }
    }

    /// Clears every failsafe, latched ones included (on arming and on disarming).
    pub fn clear(&mut self) {
        self.active = Default::default();
    }

    /// Whether `cause` is active.
    pub fn is_active(&self, cause: FailsafeCause) -> bool {
        self.active[slot(cause)].is_some()
    }

    /// The active failsafe whose action takes precedence (the earliest among equals).
    pub fn worst(&self) -> Option<Failsafe> {
        self.active.iter().flatten().copied().fold(None, |best: Option<Failsafe>, f| match best {
            Some(b) if b.action > f.action || (b.action == f.action && b.since <= f.since) => Some(b),
            _ => Some(f),
        })
    }

    /// Every firing so far.
    pub fn log(&self) -> &[FailsafeRecord] {
        &self.log
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn held_for_counts_from_the_first_true_check_and_resets_when_false() {
        let mut h = HeldFor::default();
        let s = |secs: u64| Time::from_micros(secs * 1_000_000);
        assert!(!h.check(s(1), true, 10.0));
        assert!(!h.check(s(10), true, 10.0));
        assert!(h.check(s(11), true, 10.0));
        assert!(!h.check(s(12), false, 10.0));
        assert!(!h.check(s(13), true, 10.0), "the timer restarts");
        assert!(h.check(s(13), true, 0.0), "no timer: at once");
    }

    #[test]
    fn the_highest_action_wins_and_latched_causes_stay() {
        let mut m = FailsafeMonitor::default();
        m.set(Time(1), FailsafeCause::DataLinkLost, true, FailsafeAction::ReturnToLaunch);
        m.set(Time(2), FailsafeCause::BatteryCritical, true, FailsafeAction::Land);
        m.set(Time(3), FailsafeCause::GeofenceBreach, true, FailsafeAction::Warn);
        assert_eq!(m.worst().map(|f| f.cause), Some(FailsafeCause::BatteryCritical));
        m.set(Time(4), FailsafeCause::BatteryCritical, false, FailsafeAction::Land);
        m.set(Time(4), FailsafeCause::DataLinkLost, false, FailsafeAction::ReturnToLaunch);
        assert_eq!(m.worst().map(|f| f.cause), Some(FailsafeCause::BatteryCritical));
        assert!(!m.is_active(FailsafeCause::DataLinkLost));
        assert_eq!(m.log().len(), 3);
    }
}
