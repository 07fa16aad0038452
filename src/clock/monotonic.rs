//! The clock for real runs: the OS monotonic clock, counted from process start.

use kestrel_proto::clock::Sleep;
use kestrel_proto::{Clock, Time};
use tokio::time::Instant;

/// Monotonic time since the clock was created; sleeps are tokio timers.
pub struct MonotonicClock {
    origin: Instant,
}

impl MonotonicClock {
    /// A clock whose origin is now.
    pub fn new() -> MonotonicClock {
        MonotonicClock { origin: Instant::now() }
    }
}

impl Default for MonotonicClock {
    fn default() -> Self {
        Self::new()
    }
}

impl Clock for MonotonicClock {
    fn now(&self) -> Time {
        Time::from_micros(u64::try_from(self.origin.elapsed().as_micros()).unwrap_or(u64::MAX))
    }

    fn sleep_until(&self, deadline: Time) -> Sleep {
        let at = self.origin + std::time::Duration::from_micros(deadline.as_micros());
        Box::pin(tokio::time::sleep_until(at))
    }
}
