//! Timing parameters from a config, checked before they become a [`Duration`].
//!
//! `Duration::from_secs_f64` panics on a negative, non-finite or overflowing value, and a timer
//! of a nanosecond would keep a lockstep graph busy forever; every actor turns its rates and
//! periods into durations here, so the limits are one fact, and a bad value is an
//! [`ActorError::Params`] naming the field and its value, which the runtime places at the
//! field's line in the config.

use std::time::Duration;

use crate::actor::ActorError;

/// Longest period or timeout an actor parameter may hold (s): a day.
pub const MAX_PERIOD_S: f64 = 86_400.0;
/// Fastest rate an actor parameter may ask for (Hz): faster than any sensor or loop we run
/// (the IMU's 8 kHz gyro output is the fastest), slow enough for a lockstep graph to keep up.
pub const MAX_RATE_HZ: f64 = 10_000.0;
/// Slowest rate (Hz): one tick per [`MAX_PERIOD_S`].
pub const MIN_RATE_HZ: f64 = 1.0 / MAX_PERIOD_S;

/// `value` seconds of parameter `field`, which must lie in `min_s..=max_s` (within
/// `0..=MAX_PERIOD_S`).
pub fn seconds(field: &str, value: f64, min_s: f64, max_s: f64) -> Result<Duration, ActorError> {
    let (lo, hi) = (min_s.max(0.0), max_s.min(MAX_PERIOD_S));
    if (lo..=hi).contains(&value) {
        Ok(Duration::from_secs_f64(value))
    } else {
        Err(ActorError::Params(format!("{field} = {value:?}: expected {lo}..={hi} seconds")))
    }
}

/// [`seconds`] for a value that must be positive: `(0, max_s]`.
pub fn positive_seconds(field: &str, value: f64, max_s: f64) -> Result<Duration, ActorError> {
    let hi = max_s.min(MAX_PERIOD_S);
    if value > 0.0 && value <= hi {
        Ok(Duration::from_secs_f64(value))
    } else {
        Err(ActorError::Params(format!("{field} = {value:?}: expected a number of seconds in (0, {hi}]")))
    }
}

/// The period of rate `hz` of parameter `field`, which must lie in `min_hz..=max_hz` (within
/// `MIN_RATE_HZ..=MAX_RATE_HZ`).
pub fn period_of_rate(field: &str, hz: f64, min_hz: f64, max_hz: f64) -> Result<Duration, ActorError> {
    let (lo, hi) = (min_hz.max(MIN_RATE_HZ), max_hz.min(MAX_RATE_HZ));
    if (lo..=hi).contains(&hz) {
        Ok(Duration::from_secs_f64(1.0 / hz))
    } else {
        Err(ActorError::Params(format!("{field} = {hz:?}: expected {lo}..={hi} Hz")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_a_duration_cannot_hold_are_errors_naming_the_field() {
        for bad in [f64::INFINITY, f64::NAN, 1e30, -1.0] {
            let err = seconds("timeout_s", bad, 0.0, 60.0).unwrap_err();
            assert!(err.to_string().contains("timeout_s"), "{err}");
            assert!(positive_seconds("timeout_s", bad, 60.0).is_err());
        }
        assert!(positive_seconds("timeout_s", 0.0, 60.0).is_err());
        for bad in [0.0, 1e-300, f64::NAN, f64::INFINITY, 1e9] {
            let err = period_of_rate("rate_hz", bad, 0.0, f64::INFINITY).unwrap_err();
            assert!(err.to_string().contains("rate_hz"), "{err}");
        }
        assert_eq!(period_of_rate("rate_hz", 400.0, 1.0, 1000.0).unwrap(), Duration::from_micros(2500));
        assert_eq!(seconds("lag_s", 0.0, 0.0, 1.0).unwrap(), Duration::ZERO);
    }
}
