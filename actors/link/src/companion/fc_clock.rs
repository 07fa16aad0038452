//! The flight controller's clock against ours, from TIMESYNC (mavlink.io "Time
//! Synchronization"): we ask with `tc1` 0 and `ts1` our time (ns); the flight controller answers
//! with `tc1` its time since boot (ns; ArduPilot's `micros64() · 1000`, PX4's
//! `hrt_absolute_time() · 1000`) and our `ts1` mirrored. Assuming a symmetric path, its clock read
//! `tc1` at our `(ts1 + now) / 2`; the answer with the shortest round trip of the last
//! [`WINDOW`] is the one trusted, as MAVSDK and PX4's `timesync` prefer fast round trips.
//!
//! A flight controller that reboots starts its clock again: an answer that moves the offset by
//! more than [`JUMP_US`] restarts the window, and so does its boot time going back
//! ([`FcClock::reset`], called by the state reader). Held by the tests below.

use std::collections::VecDeque;

use kestrel_proto::Time;
use mavlink::dialects::ardupilotmega::TIMESYNC_DATA;

/// Answers kept; the fastest round trip of them gives the offset.
pub const WINDOW: usize = 8;
/// Round trips longer than this are not used (µs): the midpoint could be off by half of it.
pub const MAX_RTT_US: u64 = 200_000;
/// An offset this far (µs) from the trusted one is a restarted clock, not noise.
pub const JUMP_US: i64 = 100_000;
/// Requests still awaited (an answer to anything else is someone else's).
const OUTSTANDING: usize = 8;

/// One answer: its round trip and the offset it gave.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Sample {
    rtt_us: u64,
    /// Flight controller's time minus ours (µs).
    offset_us: i64,
}

/// The offset between the flight controller's boot clock and ours.
#[derive(Debug, Default)]
pub struct FcClock {
    samples: VecDeque<Sample>,
    /// `ts1` of our requests not yet answered (ns).
    outstanding: VecDeque<i64>,
    /// Answers that matched no request of ours (another component's, or late).
    pub foreign_answers: u64,
}

impl FcClock {
    /// A clock that knows nothing yet.
    pub fn new() -> FcClock {
        FcClock::default()
    }

    /// A TIMESYNC request stamped `now`, for `target` (system, component).
    pub fn request(&mut self, now: Time, target: (u8, u8)) -> TIMESYNC_DATA {
        let ts1 = ns(now);
        if self.outstanding.len() == OUTSTANDING {
            self.outstanding.pop_front();
        }
        self.outstanding.push_back(ts1);
        TIMESYNC_DATA { tc1: 0, ts1, target_system: target.0, target_component: target.1 }
    }

    /// A TIMESYNC from the flight controller at `now`: true when it was the answer to one of
    /// our requests and was used.
    pub fn on_timesync(&mut self, t: &TIMESYNC_DATA, now: Time) -> bool {
        if t.tc1 <= 0 {
            return false;
        }
        let Some(i) = self.outstanding.iter().position(|&ts1| ts1 == t.ts1) else {
            self.foreign_answers += 1;
            return false;
        };
        self.outstanding.remove(i);
        let now_ns = ns(now);
        let Ok(rtt_ns) = u64::try_from(now_ns - t.ts1) else { return false };
        let rtt_us = rtt_ns / 1000;
        if rtt_us > MAX_RTT_US {
            return false;
        }
        let midpoint_us = (t.ts1 / 1000 + now_ns / 1000) / 2;
        let sample = Sample { rtt_us, offset_us: t.tc1 / 1000 - midpoint_us };
        if let Some(offset) = self.offset_us()
            && (sample.offset_us - offset).abs() > JUMP_US
        {
            self.samples.clear();
        }
        if self.samples.len() == WINDOW {
            self.samples.pop_front();
        }
        self.samples.push_back(sample);
        true
    }

    /// Forgets every answer (the flight controller rebooted).
    pub fn reset(&mut self) {
        self.samples.clear();
        self.outstanding.clear();
    }

    /// Whether an offset is known.
    pub fn synced(&self) -> bool {
        !self.samples.is_empty()
    }

    /// Answers held (the request rate slows once the window is full).
    pub fn samples(&self) -> usize {
        self.samples.len()
    }

    /// Flight controller's time minus ours (µs), from the fastest answer held.
    pub fn offset_us(&self) -> Option<i64> {
        self.samples.iter().min_by_key(|s| s.rtt_us).map(|s| s.offset_us)
    }

    /// Our time of the flight controller's boot time `fc_us` (µs); `None` before the first
    /// answer or when it falls before our clock's zero.
    pub fn to_local(&self, fc_us: u64) -> Option<Time> {
        let local = i64::try_from(fc_us).ok()?.checked_sub(self.offset_us()?)?;
        u64::try_from(local).ok().map(Time::from_micros)
    }

    /// The flight controller's boot time (µs) of our `time`; `None` before the first answer or
    /// before its boot.
    pub fn to_fc(&self, time: Time) -> Option<u64> {
        let fc = i64::try_from(time.as_micros()).ok()?.checked_add(self.offset_us()?)?;
        u64::try_from(fc).ok()
    }
}

fn ns(t: Time) -> i64 {
    i64::try_from(t.as_micros()).unwrap_or(i64::MAX / 1000).saturating_mul(1000)
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    /// A flight controller whose clock reads ours plus `offset_us`, answering after `up_us` and
    /// returning after `down_us`.
    fn exchange(c: &mut FcClock, sent_us: u64, offset_us: i64, up_us: u64, down_us: u64) -> bool {
        let request = c.request(Time::from_micros(sent_us), (1, 1));
        let fc_us = sent_us as i64 + up_us as i64 + offset_us;
        let answer =
            TIMESYNC_DATA { tc1: fc_us * 1000, ts1: request.ts1, target_system: 1, target_component: 196 };
        c.on_timesync(&answer, Time::from_micros(sent_us + up_us + down_us))
    }

    #[test]
    fn a_symmetric_round_trip_gives_the_offset_exactly_both_ways() {
        let mut c = FcClock::new();
        assert_eq!((c.to_local(5), c.to_fc(Time::from_micros(5))), (None, None), "nothing before an answer");
        assert!(exchange(&mut c, 10_000_000, -4_000_000, 1500, 1500));
        assert_eq!(c.offset_us(), Some(-4_000_000));
        assert_eq!(c.to_local(6_000_000), Some(Time::from_micros(10_000_000)));
        assert_eq!(c.to_fc(Time::from_micros(10_000_000)), Some(6_000_000));
        // Our 1 s is before the flight controller booted.
        assert_eq!(c.to_fc(Time::from_micros(1_000_000)), None);
    }

    #[test]
    fn the_fastest_round_trip_wins_and_foreign_or_slow_answers_are_not_used() {
        let mut c = FcClock::new();
        // Asymmetric and slow: 30 ms up, 2 ms down puts the midpoint 14 ms off.
        assert!(exchange(&mut c, 1_000_000, 500_000, 30_000, 2_000));
        assert_eq!(c.offset_us(), Some(514_000));
        assert!(exchange(&mut c, 2_000_000, 500_000, 100, 100));
        assert_eq!(c.offset_us(), Some(500_000));
        // A ground station's answer (its own ts1) and one past MAX_RTT_US change nothing.
        let foreign = TIMESYNC_DATA { tc1: 9, ts1: 12_345, target_system: 255, target_component: 190 };
        assert!(!c.on_timesync(&foreign, Time::from_micros(3_000_000)));
        assert!(!exchange(&mut c, 3_000_000, 0, 150_000, 150_000));
        assert_eq!((c.offset_us(), c.foreign_answers), (Some(500_000), 1));
        // A request (tc1 0) is not an answer.
        let request = TIMESYNC_DATA { tc1: 0, ts1: 1, ..Default::default() };
        assert!(!c.on_timesync(&request, Time::from_micros(4_000_000)));
    }

    #[test]
    fn a_rebooted_flight_controller_clock_replaces_the_old_offset_at_once() {
        let mut c = FcClock::new();
        assert!(exchange(&mut c, 100_000_000, 50_000_000, 100, 100));
        // Rebooted: its clock now reads 2 s at our 101 s, with a slower round trip.
        assert!(exchange(&mut c, 101_000_000, -99_000_000, 5_000, 5_000));
        assert_eq!(c.offset_us(), Some(-99_000_000));
    }

    proptest! {
        /// With symmetric delays the offset is exact whatever the clocks and the delay, and
        /// mapping a time there and back is the identity.
        #[test]
        fn symmetric_delays_give_an_exact_invertible_offset(
            sent_us in 1_000_000u64..1_000_000_000,
            offset_us in -900_000i64..1_000_000_000,
            delay_us in 0u64..90_000,
            t_us in 1_000_000u64..2_000_000_000,
        ) {
            let mut c = FcClock::new();
            prop_assert!(exchange(&mut c, sent_us, offset_us, delay_us, delay_us));
            prop_assert_eq!(c.offset_us(), Some(offset_us));
            let t = Time::from_micros(t_us);
            prop_assert_eq!(c.to_fc(t).and_then(|fc| c.to_local(fc)), Some(t));
        }
    }
}
