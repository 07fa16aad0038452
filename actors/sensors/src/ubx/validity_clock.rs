//! Mapping the receiver's epoch time (NAV-PVT `iTOW`) onto the graph clock, so each fix is
//! stamped with when it was *valid*, not when it arrived.
//!
//! The receiver's epochs are evenly spaced in GPS time, while their arrival on the serial line
//! jitters with the receiver's load and the host's scheduling. The clock tracks the smallest
//! arrival − iTOW offset seen (the least-delayed frame), letting it creep up slowly so that
//! crystal drift between receiver and host (tens of ppm) cannot freeze a stale minimum, and
//! subtracts the receiver's fixed solution latency, which iTOW alone cannot reveal (u-blox M8:
//! tens of milliseconds after the epoch at 5 Hz; measure it against PPS or take the lag the
//! estimator expects). A jump backwards (week rollover) or a gap restarts the estimate.

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::time::duration_micros;

/// How much the offset may grow per epoch without a new minimum (µs): 20 µs at 5 Hz is
/// 100 ppm, above any crystal's drift.
const CREEP_US: i64 = 20;
/// A gap between epochs after which the estimate restarts (ms).
const MAX_GAP_MS: u32 = 10_000;

/// iTOW → graph time.
#[derive(Clone, Debug)]
pub struct ValidityClock {
    /// Receiver's delay from the epoch to the first byte of the fastest frame (µs).
    latency_us: i64,
    /// Smallest arrival − iTOW seen, allowed to creep (µs).
    offset_us: Option<i64>,
    last_itow_ms: Option<u32>,
}

impl ValidityClock {
    /// A clock for a receiver whose least-delayed solution arrives `latency` after its epoch.
    pub fn new(latency: Duration) -> ValidityClock {
        ValidityClock {
            latency_us: i64::try_from(duration_micros(latency)).unwrap_or(i64::MAX),
            offset_us: None,
            last_itow_ms: None,
        }
    }

    /// The time of validity of the epoch `itow_ms` whose frame arrived at `arrival`; never
    /// later than `arrival` and never before the clock's origin.
    pub fn time_of_validity(&mut self, itow_ms: u32, arrival: Time) -> Time {
        let restart = match self.last_itow_ms {
            Some(last) => itow_ms < last || itow_ms - last > MAX_GAP_MS,
            None => true,
        };
        self.last_itow_ms = Some(itow_ms);
        let arrival_us = i64::try_from(arrival.as_micros()).unwrap_or(i64::MAX);
        let candidate = arrival_us - i64::from(itow_ms) * 1000;
        let offset = match self.offset_us {
            Some(offset) if !restart => candidate.min(offset + CREEP_US),
            _ => candidate,
        };
        self.offset_us = Some(offset);
        let valid_us = (i64::from(itow_ms) * 1000 + offset - self.latency_us).clamp(0, arrival_us);
        Time::from_micros(valid_us as u64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jittery_arrivals_give_evenly_spaced_times() {
        let mut clock = ValidityClock::new(Duration::from_millis(50));
        let jitter_us = [30_000, 0, 12_000, 4_000, 25_000, 1_000];
        let times: Vec<u64> = (0..6u32)
            .map(|k| {
                let itow = 100_000 + 200 * k;
                let arrival =
                    Time::from_micros(5_000_000 + 200_000 * u64::from(k) + 80_000 + jitter_us[k as usize]);
                clock.time_of_validity(itow, arrival).as_micros()
            })
            .collect();
        // From the second epoch on, the least-delayed arrival (80 ms) anchors the offset.
        for pair in times[1..].windows(2) {
            assert!((pair[1] as i64 - pair[0] as i64 - 200_000).abs() <= CREEP_US, "{times:?}");
        }
        assert!(
            (times[5] as i64 - (5_000_000 + 1_000_000 + 30_000)).abs() <= 4 * CREEP_US + 1_000,
            "{times:?}"
        );
    }

    #[test]
    fn week_rollover_restarts_and_times_never_exceed_arrival() {
        let mut clock = ValidityClock::new(Duration::from_millis(500));
        let late = clock.time_of_validity(604_799_800, Time::from_micros(1_000_000));
        assert_eq!(late, Time::from_micros(500_000));
        let after = clock.time_of_validity(0, Time::from_micros(1_200_000));
        assert_eq!(after, Time::from_micros(700_000));
        let mut early = ValidityClock::new(Duration::from_secs(5));
        assert_eq!(early.time_of_validity(10, Time::from_micros(1_000)), Time::ZERO);
    }
}
