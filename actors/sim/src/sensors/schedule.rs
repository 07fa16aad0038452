//! When sensors sample and when their samples are released.
//!
//! Times are integer microseconds, so rates and lags are exact and a run is repeatable.

use std::collections::VecDeque;

use kestrel_proto::Time;

/// Microseconds between samples at `rate_hz` (at least 1).
pub(crate) fn period_us(rate_hz: f64) -> u64 {
    ((1e6 / rate_hz).round() as u64).max(1)
}

/// A periodic sampling schedule.
#[derive(Clone, Debug)]
pub(crate) struct Periodic {
    period_us: u64,
    next_due: Time,
}

impl Periodic {
    /// First sample one period after `start`.
    pub(crate) fn new(rate_hz: f64, start: Time) -> Periodic {
        let period_us = period_us(rate_hz);
        Periodic { period_us, next_due: Time(start.0 + period_us) }
    }

    /// Whether a sample is due at `now`; if so, schedules the next one.
    pub(crate) fn due(&mut self, now: Time) -> bool {
        if now < self.next_due {
            return false;
        }
        while self.next_due <= now {
            self.next_due = Time(self.next_due.0 + self.period_us);
        }
        true
    }
}

/// Samples waiting out their lag: measured at `time`, released at `time + lag`.
#[derive(Clone, Debug)]
pub(crate) struct Delayed<T> {
    lag_us: u64,
    pending: VecDeque<(Time, T)>,
}

impl<T> Delayed<T> {
    /// Room for every sample that can be in flight at `rate_hz`, so steady state never allocates.
    pub(crate) fn new(lag_s: f64, rate_hz: f64) -> Delayed<T> {
        let lag_us = (lag_s * 1e6).round() as u64;
        let in_flight = (lag_us / period_us(rate_hz)) as usize + 2;
        Delayed { lag_us, pending: VecDeque::with_capacity(in_flight) }
    }

    /// Queues a sample measured at `measured`.
    pub(crate) fn push(&mut self, measured: Time, sample: T) {
        self.pending.push_back((Time(measured.0 + self.lag_us), sample));
    }

    /// Hands every sample whose release time is ≤ `now` to `release`, oldest first.
    pub(crate) fn release(&mut self, now: Time, mut release: impl FnMut(T)) {
        while self.pending.front().is_some_and(|(at, _)| *at <= now) {
            if let Some((_, sample)) = self.pending.pop_front() {
                release(sample);
            }
        }
    }
}
