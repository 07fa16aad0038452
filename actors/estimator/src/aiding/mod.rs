//! The aiding sources as PX4 EKF2's `aid_sources/*`: for each, a `*_control.rs` deciding *when*
//! to fuse (checks, gates, timeouts, resets, fallbacks) beside a file holding *the maths* of the
//! observation, so a rule can be read and tested without the algebra and the other way round.

pub mod baro;
pub mod baro_control;
pub mod drag;
pub mod drag_control;
pub mod gps;
pub mod gps_control;
pub mod mag;
pub mod mag_control;
pub mod mag_yaw_reset;

use kestrel_proto::Time;
use kestrel_proto::messages::Innovation;

/// What a source's gate check leads to, given how long it has been failing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Inside the gate: fuse.
    Fuse,
    /// Outside the gate, not yet for long: skip the sample (the filter is trusted).
    Reject,
    /// Outside the gate without a break for longer than the timeout: the source, consistent
    /// with itself, is trusted over the filter (EKF2 resets to it after `reset_timeout_max`).
    TimedOut,
}

/// A run of consecutive gate failures of one source.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RejectionRun {
    since: Option<Time>,
}

impl RejectionRun {
    /// Judges a sample at `now` that `passes` its gate or not; a run longer than `timeout_s`
    /// times out once and starts over.
    pub fn judge(&mut self, now: Time, passes: bool, timeout_s: f64) -> Verdict {
        if passes {
            self.since = None;
            return Verdict::Fuse;
        }
        let since = *self.since.get_or_insert(now);
        if now.saturating_since(since).as_secs_f64() > timeout_s {
            self.since = None;
            Verdict::TimedOut
        } else {
            Verdict::Reject
        }
    }

    /// Forgets the run (after a reset).
    pub fn clear(&mut self) {
        self.since = None;
    }
}

/// Whether `last` lies within `timeout_s` before `now`.
pub fn recent(last: Option<Time>, now: Time, timeout_s: f64) -> bool {
    last.is_some_and(|t| now.saturating_since(t).as_secs_f64() < timeout_s)
}

/// An innovation `y` with variance `s`, gated at `gate_sigma` standard deviations.
pub fn innovation(y: f64, s: f64, gate_sigma: f64) -> Innovation {
    let test_ratio = if s > 0.0 { y * y / (gate_sigma * gate_sigma * s) } else { f64::INFINITY };
    Innovation { innovation: y, variance: s, test_ratio }
}

/// Whether every innovation passes its chi-square gate.
pub fn passes(innovations: &[Innovation]) -> bool {
    innovations.iter().all(|i| i.test_ratio <= 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn test_ratio_is_one_at_the_gate() {
        assert!((innovation(5.0, 1.0, 5.0).test_ratio - 1.0).abs() < 1e-12);
        assert!(passes(&[innovation(4.9, 1.0, 5.0)]));
        assert!(!passes(&[innovation(0.0, 1.0, 5.0), innovation(10.0, 1.0, 5.0)]));
    }

    #[test]
    fn a_rejection_run_times_out_once_after_its_timeout_and_a_pass_ends_it() {
        let t = Time::from_secs_f64;
        let mut run = RejectionRun::default();
        assert_eq!(run.judge(t(1.0), false, 2.0), Verdict::Reject);
        assert_eq!(run.judge(t(3.0), false, 2.0), Verdict::Reject, "exactly the timeout is not past it");
        assert_eq!(run.judge(t(3.1), false, 2.0), Verdict::TimedOut);
        assert_eq!(run.judge(t(3.2), false, 2.0), Verdict::Reject, "a new run starts");
        assert_eq!(run.judge(t(4.0), true, 2.0), Verdict::Fuse);
        assert_eq!(run.judge(t(5.5), false, 2.0), Verdict::Reject, "the pass ended the run");
        assert_eq!(run.judge(t(7.0), false, 2.0), Verdict::Reject);
        assert_eq!(run.judge(t(7.6), false, 2.0), Verdict::TimedOut);
    }

    #[test]
    fn recent_is_strictly_within_the_timeout() {
        let t = Time::from_secs_f64;
        assert!(recent(Some(t(1.0)), t(1.5), 1.0));
        assert!(!recent(Some(t(1.0)), t(2.0), 1.0));
        assert!(!recent(None, t(2.0), 1.0));
    }
}
