//! The replay's pure core: a log's messages in the order they were recorded, and the mapping
//! from recorded log time to the graph-clock instant each goes out at. No I/O, no clock.

use std::collections::VecDeque;

use kestrel_proto::Time;

/// Messages in recorded order, each with the log time the recorder stamped on it (when the
/// runtime received it, not when it was measured: replaying at log time reproduces each
/// sensor's lag as the estimator saw it).
#[derive(Debug)]
pub struct Schedule<M> {
    entries: VecDeque<(Time, M)>,
}

impl<M> Schedule<M> {
    /// Orders `entries` by log time; equal times keep the order given (file order per topic,
    /// topics in the order read), so a replay is deterministic.
    pub fn new(mut entries: Vec<(Time, M)>) -> Schedule<M> {
        entries.sort_by_key(|(t, _)| *t);
        Schedule { entries: entries.into() }
    }

    /// Log time of the first message.
    pub fn first_log_time(&self) -> Option<Time> {
        self.entries.front().map(|(t, _)| *t)
    }

    /// Messages not yet taken.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether every message has been taken.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Takes the next message with its log time.
    pub fn pop(&mut self) -> Option<(Time, M)> {
        self.entries.pop_front()
    }
}

/// Where recorded log time lands on the graph clock.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pace {
    log_origin: Time,
    graph_origin: Time,
    /// Log seconds per graph second.
    speed: f64,
}

impl Pace {
    /// Pacing for a log whose first message was recorded at `first_log_time`, started at
    /// graph time `now`, at `speed` (log seconds per graph second, > 0).
    ///
    /// The first message goes out at its own log time if the graph clock has not passed it yet
    /// — so a lockstep run from zero at speed 1 publishes every message at exactly its recorded
    /// log time — or at `now` if it has; later ones keep their recorded spacing, divided by
    /// `speed`.
    pub fn new(first_log_time: Time, now: Time, speed: f64) -> Pace {
        Pace { log_origin: first_log_time, graph_origin: now.max(first_log_time), speed }
    }

    /// The graph time at which the message recorded at `log_time` is due (the end of time for
    /// one a slow pace puts beyond what a `Duration` holds).
    pub fn graph_time(&self, log_time: Time) -> Time {
        let since = log_time.saturating_since(self.log_origin).as_secs_f64() / self.speed;
        self.graph_origin + std::time::Duration::try_from_secs_f64(since).unwrap_or(std::time::Duration::MAX)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(us: u64) -> Time {
        Time::from_micros(us)
    }

    #[test]
    fn a_pace_too_slow_for_a_duration_saturates_instead_of_panicking() {
        let pace = Pace::new(t(0), t(0), 1e-300);
        assert_eq!(pace.graph_time(t(10_000_000)), Time::from_micros(u64::MAX));
    }

    #[test]
    fn messages_come_out_in_log_time_order_and_ties_keep_their_order() {
        let mut schedule =
            Schedule::new(vec![(t(30), "gps"), (t(10), "imu a"), (t(20), "imu b"), (t(10), "baro")]);
        assert_eq!(schedule.first_log_time(), Some(t(10)));
        let order: Vec<_> = std::iter::from_fn(|| schedule.pop()).map(|(_, m)| m).collect();
        assert_eq!(order, ["imu a", "baro", "imu b", "gps"]);
        assert!(schedule.is_empty());
    }

    #[test]
    fn at_speed_one_a_graph_that_starts_first_replays_at_the_recorded_times() {
        let pace = Pace::new(t(2_500), t(0), 1.0);
        assert_eq!(pace.graph_time(t(2_500)), t(2_500));
        assert_eq!(pace.graph_time(t(1_000_000)), t(1_000_000));
    }

    #[test]
    fn a_graph_already_past_the_log_shifts_it_and_speed_divides_the_spacing() {
        let pace = Pace::new(t(1_000), t(50_000), 2.0);
        assert_eq!(pace.graph_time(t(1_000)), t(50_000));
        assert_eq!(pace.graph_time(t(201_000)), t(150_000));
        // A message stamped before the first (not produced by `Schedule`) is due at once.
        assert_eq!(pace.graph_time(t(0)), t(50_000));
    }
}
