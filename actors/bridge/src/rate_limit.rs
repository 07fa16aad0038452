//! A ceiling on how often the bridge sends one topic (`max_rate_hz`): a radio link carries far
//! less than loopback, and a state topic (the estimator's NavState, some 340 Hz) needs only its
//! newest value at the far end.

use kestrel_proto::Time;

/// Admits a message when at least `1 / max_rate_hz` has passed on the graph clock since the one
/// it last admitted; the others are dropped (the next state supersedes them).
#[derive(Clone, Debug)]
pub struct RateLimit {
    interval_us: u64,
    last: Option<Time>,
}

impl RateLimit {
    /// At most `max_rate_hz` messages a second (checked finite and above 0 by the parameters).
    pub fn new(max_rate_hz: f64) -> RateLimit {
        RateLimit { interval_us: (1e6 / max_rate_hz).round() as u64, last: None }
    }

    /// Whether a message handled at `now` is sent.
    pub fn admit(&mut self, now: Time) -> bool {
        let due =
            self.last.is_none_or(|last| now.as_micros().saturating_sub(last.as_micros()) >= self.interval_us);
        if due {
            self.last = Some(now);
        }
        due
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    proptest! {
        /// Against a plain replay of the rule: the admitted messages are never closer than the
        /// interval, and a message that far from the last admitted one is never dropped.
        #[test]
        fn admits_exactly_the_messages_an_interval_apart(
            rate_hz in 0.5f64..1000.0,
            gaps_us in proptest::collection::vec(0u64..20_000, 1..400),
        ) {
            let mut limit = RateLimit::new(rate_hz);
            let interval_us = (1e6 / rate_hz).round() as u64;
            let mut t = 0u64;
            let mut last_admitted: Option<u64> = None;
            for gap in gaps_us {
                t += gap;
                let expected = last_admitted.is_none_or(|last| t - last >= interval_us);
                prop_assert_eq!(limit.admit(Time::from_micros(t)), expected, "t {} µs", t);
                if expected {
                    last_admitted = Some(t);
                }
            }
        }
    }

    #[test]
    fn a_340_hz_stream_limited_to_50_hz_sends_at_most_50_a_second() {
        let mut limit = RateLimit::new(50.0);
        let sent = (0..340u64).filter(|k| limit.admit(Time::from_micros(k * 1_000_000 / 340))).count();
        assert!((45..=50).contains(&sent), "{sent} sent in 1 s");
    }
}
