//! Admission of lagged observations into the delay buffers: a sample the filter can no longer
//! use at its own time is counted and dropped on arrival, so it never blocks a buffer or lands
//! at the wrong time (PX4 EKF2 drops a sample older than the oldest IMU sample it buffers).
//!
//! * Older than the delayed fusion horizon: the filter has already passed its time; fused now
//!   it would meet a state up to the horizon later than it was measured.
//! * Not newer than the last sample accepted from the same sensor (its clock went backwards, or
//!   a duplicate): fusing it would apply old information after newer.
//! * Stamped further ahead of the newest IMU sample than [`FUTURE_TOLERANCE_US`]: it would sit at
//!   the head of its buffer, holding every sample behind it until that time, and as the
//!   sensor's newest time it would turn every good sample after it into "going backwards".
//!
//! A refused sample does not move the sensor's newest time, so the next good one is fused.

use kestrel_proto::Time;

use crate::error::InputError;

/// How far ahead of the newest IMU sample an observation may be stamped (µs): sensors sampled in
/// the same instant as an IMU sample may arrive just before it.
pub const FUTURE_TOLERANCE_US: u64 = 100_000;

/// The newest accepted time of one sensor and the samples it refused.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Arrivals {
    newest: Option<Time>,
    /// Samples refused (out of order, behind the horizon or from the future).
    pub dropped: u64,
}

impl Arrivals {
    /// Accepts a sample of `sensor` measured at `time` when it is newer than the last accepted
    /// one, not behind `horizon` (the filter's time; `None` when samples are fused on arrival,
    /// without lag compensation) and not beyond `newest_imu` plus the tolerance; otherwise counts
    /// it.
    pub fn admit(
        &mut self,
        sensor: &'static str,
        time: Time,
        horizon: Option<Time>,
        newest_imu: Time,
    ) -> Result<(), InputError> {
        let refusal = if let Some(horizon) = horizon.filter(|&h| time < h) {
            Some(InputError::BehindHorizon { sensor, time, horizon })
        } else if let Some(newest) = self.newest.filter(|&n| time <= n) {
            Some(InputError::OutOfOrder { sensor, time, newest })
        } else if time.as_micros() > newest_imu.as_micros() + FUTURE_TOLERANCE_US {
            Some(InputError::FromFuture { sensor, time, newest_imu })
        } else {
            None
        };
        match refusal {
            Some(e) => {
                self.dropped += 1;
                Err(e)
            }
            None => {
                self.newest = Some(time);
                Ok(())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(ms: u64) -> Time {
        Time::from_micros(ms * 1000)
    }

    #[test]
    fn refusals_are_counted_and_do_not_move_the_newest_time() {
        let mut a = Arrivals::default();
        let (horizon, imu) = (t(780), t(1000));
        assert!(a.admit("gps", t(800), Some(horizon), imu).is_ok());
        assert!(matches!(a.admit("gps", t(790), Some(horizon), imu), Err(InputError::OutOfOrder { .. })));
        assert!(matches!(a.admit("gps", t(800), Some(horizon), imu), Err(InputError::OutOfOrder { .. })));
        assert!(matches!(a.admit("gps", t(5000), Some(horizon), imu), Err(InputError::FromFuture { .. })));
        assert_eq!(a.dropped, 3);
        // The future sample did not become the newest: the next good one passes.
        assert!(a.admit("gps", t(1000), Some(horizon), imu).is_ok());
        let mut b = Arrivals::default();
        assert!(matches!(b.admit("baro", t(700), Some(horizon), imu), Err(InputError::BehindHorizon { .. })));
        assert!(b.admit("baro", t(780), Some(horizon), imu).is_ok());
        assert_eq!(b.dropped, 1);
    }
}
