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

/// A condition that counts once it has held for `for_s` in all, net of the breaks between:
/// time it holds adds up, time it does not pays the sum back at half the rate. A navigation
/// state that comes back for a moment once a second is as good as gone, where a [`HeldFor`]
/// would restart at every return and never fire; a state late for 150 ms now and then (a
/// non-realtime host) pays it back within 0.3 s. PX4 likewise wants position checks passing
/// for a probation time (`COM_POS_FS_PROB`) before it trusts them again.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NetHeldFor {
    held_s: f64,
    last: Option<Time>,
}

impl NetHeldFor {
    /// Whether `condition`, true now, has held for `for_s` net of its breaks.
    pub fn check(&mut self, now: Time, condition: bool, for_s: f64) -> bool {
        let dt_s = self.last.map_or(0.0, |t| now.saturating_since(t).as_secs_f64());
        self.last = Some(now);
        self.held_s = if condition { self.held_s + dt_s } else { (self.held_s - 0.5 * dt_s).max(0.0) };
        condition && self.held_s >= for_s
    }

    /// Forgets what has been held (on disarming).
    pub fn reset(&mut self) {
        *self = NetHeldFor::default();
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

    /// The active failsafe whose action takes precedence among all but `cause`'s.
    pub fn worst_except(&self, cause: FailsafeCause) -> Option<Failsafe> {
        self.active.iter().flatten().filter(|f| f.cause != cause).copied().fold(
            None,
            |best: Option<Failsafe>, f| match best {
                Some(b) if b.action > f.action || (b.action == f.action && b.since <= f.since) => Some(b),
                _ => Some(f),
            },
        )
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
    fn net_held_for_adds_up_returning_breaks_and_pays_them_back_at_half_rate() {
        let ms = |ms: u64| Time::from_micros(ms * 1000);
        // Held 950 ms, broken 50 ms, each second: fires in the second second.
        let mut h = NetHeldFor::default();
        let mut fired = None;
        for step in 0..=400u64 {
            let t = step * 5;
            if h.check(ms(t), t % 1000 >= 50, 1.0) {
                fired = Some(t);
                break;
            }
        }
        // 0.95 s held, 0.025 s paid back over the 50 ms break, then 0.075 s more: 1.12 s, to
        // a step of 5 ms.
        assert!(fired.is_some_and(|t| (1115..=1125).contains(&t)), "fired at {fired:?} ms");
        // Held 150 ms every 1.5 s: paid back each time, never fires.
        let mut h = NetHeldFor::default();
        assert!((0..=6000u64).all(|step| !h.check(ms(step * 5), (step * 5) % 1500 < 150, 0.5)));
        // A break does not fire even with the sum past the limit; a reset forgets it.
        let mut h = NetHeldFor::default();
        assert!(!h.check(ms(0), true, 0.1));
        assert!(h.check(ms(200), true, 0.1));
        assert!(!h.check(ms(205), false, 0.1));
        h.reset();
        assert!(!h.check(ms(210), true, 0.1));
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

    #[test]
    fn worst_except_leaves_one_cause_out() {
        let mut m = FailsafeMonitor::default();
        m.set(Time(1), FailsafeCause::GeofenceBreach, true, FailsafeAction::Land);
        assert_eq!(m.worst_except(FailsafeCause::GeofenceBreach), None);
        m.set(Time(2), FailsafeCause::DataLinkLost, true, FailsafeAction::ReturnToLaunch);
        assert_eq!(m.worst().map(|f| f.cause), Some(FailsafeCause::GeofenceBreach));
        assert_eq!(
            m.worst_except(FailsafeCause::GeofenceBreach).map(|f| f.cause),
            Some(FailsafeCause::DataLinkLost)
        );
    }
}
