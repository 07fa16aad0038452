//! The two clocks behind [`kestrel_proto::Clock`]: the OS monotonic clock for real flights and
//! the lockstep clock for simulation.

mod lockstep;
mod monotonic;

pub use lockstep::{LockstepClock, LockstepDriver};
pub use monotonic::MonotonicClock;
