//! Helpers shared by the device tests: the host's monotonic clock as a graph clock.

use std::sync::Arc;
use std::time::{Duration, Instant};

use kestrel_proto::clock::Sleep;
use kestrel_proto::{Clock, Time};

pub struct WallClock {
    origin: Instant,
}

impl WallClock {
    pub fn new() -> Arc<WallClock> {
        Arc::new(WallClock { origin: Instant::now() })
    }
}

impl Clock for WallClock {
    fn now(&self) -> Time {
        Time::from_micros(self.origin.elapsed().as_micros() as u64)
    }

    fn sleep_until(&self, deadline: Time) -> Sleep {
        let at = self.origin + Duration::from_micros(deadline.as_micros());
        Box::pin(tokio::time::sleep_until(at.into()))
    }
}
