//! The clock every actor reads time from.
//!
//! Actors never read the OS clock themselves: the runtime hands them one `Clock`, monotonic on
//! hardware, simulation time under the lockstep simulator. That is what lets the same actor
//! fly, replay a log, or run a deterministic simulation faster than real time.

use std::future::Future;
use std::pin::Pin;

use crate::time::Time;

/// A future that completes at a deadline on a [`Clock`].
pub type Sleep = Pin<Box<dyn Future<Output = ()> + Send + 'static>>;

/// The graph's notion of now.
pub trait Clock: Send + Sync + 'static {
    /// The current time.
    fn now(&self) -> Time;

    /// Completes once `now() >= deadline`. Under lockstep the clock only advances when the
    /// graph is idle, so a sleeping actor never misses simulated time.
    fn sleep_until(&self, deadline: Time) -> Sleep;
}
