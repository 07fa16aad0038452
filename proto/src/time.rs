//! Monotonic timestamps in microseconds.
//!
//! One `Time` base is shared by the whole graph: the clock the runtime hands every actor. On
//! hardware it counts from process start on the monotonic clock; in the lockstep simulator it
//! is simulation time. Microseconds in a `u64` cover 584 000 years without wrapping and keep
//! arithmetic exact, so a lockstep run is bit-for-bit repeatable.

use std::ops::{Add, Sub};
use std::time::Duration;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// A point on the graph's monotonic clock, in microseconds since the clock's origin.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize, JsonSchema,
)]
#[serde(transparent)]
pub struct Time(pub u64);

impl Time {
    /// The clock's origin.
    pub const ZERO: Time = Time(0);

    /// Microseconds since the origin.
    pub const fn as_micros(self) -> u64 {
        self.0
    }

    /// Builds a time from microseconds since the origin.
    pub const fn from_micros(us: u64) -> Time {
        Time(us)
    }

    /// Seconds since the origin, for display and physics.
    pub fn as_secs_f64(self) -> f64 {
        self.0 as f64 * 1e-6
    }

    /// The nearest microsecond to `secs` seconds since the origin (negative clamps to zero).
    pub fn from_secs_f64(secs: f64) -> Time {
        Time((secs * 1e6).round().max(0.0) as u64)
    }

    /// Time elapsed since `earlier`, zero if `earlier` is in the future.
    pub fn saturating_since(self, earlier: Time) -> Duration {
        Duration::from_micros(self.0.saturating_sub(earlier.0))
    }

    /// `self - d`, clamped at the origin.
    pub fn saturating_sub(self, d: Duration) -> Time {
        Time(self.0.saturating_sub(duration_micros(d)))
    }
}

/// A duration in whole microseconds (sub-microsecond parts are dropped).
pub fn duration_micros(d: Duration) -> u64 {
    u64::try_from(d.as_micros()).unwrap_or(u64::MAX)
}

impl Add<Duration> for Time {
    type Output = Time;
    fn add(self, d: Duration) -> Time {
        Time(self.0.saturating_add(duration_micros(d)))
    }
}

impl Sub for Time {
    type Output = Duration;
    /// Elapsed time between two stamps; saturates at zero when `rhs` is later.
    fn sub(self, rhs: Time) -> Duration {
        self.saturating_since(rhs)
    }
}

impl std::fmt::Display for Time {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:.6} s", self.as_secs_f64())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arithmetic_is_exact_in_microseconds() {
        let t = Time::from_micros(2_500);
        assert_eq!(t + Duration::from_micros(2_500), Time(5_000));
        assert_eq!(Time(5_000) - t, Duration::from_micros(2_500));
        assert_eq!(t - Time(5_000), Duration::ZERO);
        assert_eq!(Time::from_secs_f64(0.0025), t);
        assert_eq!(Time::from_secs_f64(-1.0), Time::ZERO);
    }
}
