//! OBSTACLE_DISTANCE to the flight controller: the newest obstacle sectors, laid out as
//! ArduPilot's `AP_Proximity_MAV` and PX4's collision prevention read them — 72 sectors of 5°,
//! sector 0 centred on the nose, `MAV_FRAME_BODY_FRD`, distances in cm with `UINT16_MAX` for
//! "no information" and `max_distance + 1` for "nothing within range" (ArduPilot skips both, and
//! every value below `min_distance` or above `max_distance`).
//!
//! Timing: ArduPilot drops the proximity sensor 500 ms after its last message
//! (`PROXIMITY_MAV_TIMEOUT_MS`), so the newest sectors are repeated at [`RATE_HZ`] while they are
//! younger than [`STALE`]; older ones are not sent at all, so the flight controller times the
//! sensor out instead of avoiding an obstacle that is no longer where it was. `time_usec` is the
//! capture time on the flight controller's clock ([`super::fc_clock`]); before the clocks are
//! aligned nothing is sent. Held by the tests below.

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::messages::{OBSTACLE_SECTORS, ObstacleSectors, SECTOR_UNKNOWN};
use mavlink::dialects::ardupilotmega::{MavDistanceSensor, MavFrame, OBSTACLE_DISTANCE_DATA};

use super::fc_clock::FcClock;

/// Width of each sector sent (deg): 72 sectors all round.
pub const SECTOR_DEG: f32 = 360.0 / OBSTACLE_SECTORS as f32;
/// Sectors older than this (capture time to now) are not sent (ArduPilot's own timeout).
pub const STALE: Duration = Duration::from_millis(500);
/// How often the newest sectors go out while fresh (Hz).
pub const RATE_HZ: f64 = 20.0;

/// The sectors waiting to go out and when they last went.
#[derive(Debug, Default)]
pub struct ObstacleOut {
    newest: Option<(Time, ObstacleSectors)>,
    /// When the newest sectors are due again (our clock); `None`: at once.
    next_due: Option<Time>,
    /// Sector sets refused because they were older than [`STALE`] when they arrived or when due.
    pub stale: u64,
    /// Sector sets not sent because the clocks were not aligned yet.
    pub unsynced: u64,
}

impl ObstacleOut {
    /// Nothing to send yet.
    pub fn new() -> ObstacleOut {
        ObstacleOut::default()
    }

    /// New sectors captured at `time` (sent on the next tick).
    pub fn on_sectors(&mut self, time: Time, sectors: &ObstacleSectors) {
        if self.newest.as_ref().is_some_and(|(t, _)| *t > time) {
            return;
        }
        self.newest = Some((time, resample(sectors)));
    }

    /// The OBSTACLE_DISTANCE due at `now`, if any.
    pub fn due(&mut self, now: Time, clock: &FcClock) -> Option<OBSTACLE_DISTANCE_DATA> {
        let (time, sectors) = self.newest.as_ref()?;
        if now.saturating_since(*time) > STALE {
            self.newest = None;
            self.stale += 1;
            return None;
        }
        if self.next_due.is_some_and(|due| now < due) {
            return None;
        }
        let Some(time_usec) = clock.to_fc(*time) else {
            self.unsynced += 1;
            return None;
        };
        // On a schedule of RATE_HZ, not "a period after the last send", so that a tick slower
        // than the period does not lower the rate; never catching up in a burst.
        let period = Duration::from_secs_f64(1.0 / RATE_HZ);
        let next = self.next_due.unwrap_or(now) + period;
        self.next_due = Some(if next < now { now } else { next });
        Some(message(time_usec, sectors))
    }
}

/// OBSTACLE_DISTANCE of sectors already in the 72 × 5° layout.
fn message(time_usec: u64, sectors: &ObstacleSectors) -> OBSTACLE_DISTANCE_DATA {
    let mut distances = [SECTOR_UNKNOWN; OBSTACLE_SECTORS];
    for (out, v) in distances.iter_mut().zip(&sectors.distances_cm) {
        *out = *v;
    }
    OBSTACLE_DISTANCE_DATA {
        time_usec,
        distances,
        min_distance: sectors.min_distance_cm,
        max_distance: sectors.max_distance_cm,
        sensor_type: MavDistanceSensor::MAV_DISTANCE_SENSOR_UNKNOWN,
        increment: 0,
        increment_f: SECTOR_DEG,
        angle_offset: 0.0,
        frame: MavFrame::MAV_FRAME_BODY_FRD,
    }
}

/// `sectors` in the 72 × 5° layout with sector 0 on the nose: each input sector goes to the
/// output sector its centre falls in; where several do, an obstacle beats "free", the nearer
/// obstacle beats the farther, and "free" beats "unknown". Out-of-range values below
/// `min_distance_cm` are dropped (unknown), as ArduPilot would.
pub fn resample(sectors: &ObstacleSectors) -> ObstacleSectors {
    let max = sectors.max_distance_cm;
    let free = max.saturating_add(1);
    let mut out = vec![SECTOR_UNKNOWN; OBSTACLE_SECTORS];
    let valid_increment = sectors.increment_deg.is_finite() && sectors.increment_deg != 0.0;
    let valid_offset = sectors.angle_offset_deg.is_finite();
    if valid_increment && valid_offset {
        for (i, &cm) in sectors.distances_cm.iter().enumerate() {
            let reading = if cm == SECTOR_UNKNOWN || cm < sectors.min_distance_cm {
                continue;
            } else if cm > max {
                free
            } else {
                cm
            };
            let bearing = f64::from(sectors.angle_offset_deg) + i as f64 * f64::from(sectors.increment_deg);
            let k = (bearing / f64::from(SECTOR_DEG)).round().rem_euclid(OBSTACLE_SECTORS as f64) as usize;
            let slot = &mut out[k % OBSTACLE_SECTORS];
            *slot = match *slot {
                SECTOR_UNKNOWN => reading,
                old => old.min(reading),
            };
        }
    }
    ObstacleSectors {
        distances_cm: out,
        increment_deg: SECTOR_DEG,
        angle_offset_deg: 0.0,
        min_distance_cm: sectors.min_distance_cm,
        max_distance_cm: max,
    }
}

#[cfg(test)]
mod tests {
    use mavlink::dialects::ardupilotmega::TIMESYNC_DATA;
    use proptest::prelude::*;

    use super::*;

    fn sectors(distances_cm: Vec<u16>, increment_deg: f32, angle_offset_deg: f32) -> ObstacleSectors {
        ObstacleSectors {
            distances_cm,
            increment_deg,
            angle_offset_deg,
            min_distance_cm: 20,
            max_distance_cm: 1200,
        }
    }

    /// A clock whose flight controller reads ours plus 1 s.
    fn synced() -> FcClock {
        let mut c = FcClock::new();
        let r = c.request(Time::from_micros(5_000_000), (1, 1));
        assert!(c.on_timesync(
            &TIMESYNC_DATA { tc1: 6_000_000_000, ts1: r.ts1, ..Default::default() },
            Time::from_micros(5_000_000)
        ));
        c
    }

    #[test]
    fn the_stereo_grid_layout_goes_out_unchanged_in_body_frd_with_the_flight_controller_time() {
        let mut d = vec![SECTOR_UNKNOWN; 72];
        d[0] = 300;
        d[1] = 1201;
        d[71] = 450;
        let s = sectors(d.clone(), 5.0, 0.0);
        assert_eq!(resample(&s), s);
        let mut out = ObstacleOut::new();
        out.on_sectors(Time::from_micros(10_000_000), &s);
        let m = out.due(Time::from_micros(10_050_000), &synced()).expect("fresh and synced");
        assert_eq!(m.distances.to_vec(), d);
        assert_eq!(
            (m.time_usec, m.frame, m.increment_f, m.angle_offset),
            (11_000_000, MavFrame::MAV_FRAME_BODY_FRD, 5.0, 0.0)
        );
        assert_eq!((m.min_distance, m.max_distance), (20, 1200));
    }

    #[test]
    fn a_narrow_camera_layout_lands_in_the_sectors_its_bearings_fall_in() {
        // Seven 10° sectors from -30° (left of the nose) to +30°.
        let s = sectors(vec![500, 600, SECTOR_UNKNOWN, 5, 2000, 700, 800], 10.0, -30.0);
        let r = resample(&s);
        assert_eq!(r.distances_cm[66], 500, "-30° is sector 66");
        assert_eq!(r.distances_cm[68], 600);
        assert_eq!(r.distances_cm[70], SECTOR_UNKNOWN, "unknown stays unknown");
        assert_eq!(r.distances_cm[0], SECTOR_UNKNOWN, "5 cm is below min_distance: dropped");
        assert_eq!(r.distances_cm[2], 1201, "beyond range is free: max + 1");
        assert_eq!((r.distances_cm[4], r.distances_cm[6]), (700, 800));
        assert_eq!(r.distances_cm.iter().filter(|&&v| v != SECTOR_UNKNOWN).count(), 5);
    }

    #[test]
    fn stale_or_unsynced_sectors_are_not_sent_and_fresh_ones_repeat_at_the_rate() {
        let s = sectors(vec![300; 72], 5.0, 0.0);
        let mut out = ObstacleOut::new();
        out.on_sectors(Time::from_micros(10_000_000), &s);
        assert!(out.due(Time::from_micros(10_010_000), &FcClock::new()).is_none(), "clocks not aligned");
        assert_eq!(out.unsynced, 1);
        let clock = synced();
        assert!(out.due(Time::from_micros(10_020_000), &clock).is_some());
        assert!(out.due(Time::from_micros(10_040_000), &clock).is_none(), "20 ms later: not due at 20 Hz");
        assert!(out.due(Time::from_micros(10_070_000), &clock).is_some(), "50 ms later: again");
        assert!(out.due(Time::from_micros(10_500_000), &clock).is_some(), "500 ms old: still fresh");
        assert!(out.due(Time::from_micros(10_560_000), &clock).is_none(), "older than 500 ms: never sent");
        assert_eq!(out.stale, 1);
        assert!(out.due(Time::from_micros(10_700_000), &clock).is_none(), "and not later either");
        // Older sectors arriving after newer ones are ignored.
        out.on_sectors(Time::from_micros(11_000_000), &s);
        out.on_sectors(Time::from_micros(10_900_000), &sectors(vec![100; 72], 5.0, 0.0));
        assert_eq!(out.due(Time::from_micros(11_010_000), &clock).map(|m| m.distances[0]), Some(300));
    }

    proptest! {
        /// Whatever the layout, the output has 72 sectors, every value is unknown, free
        /// (max + 1) or an in-range obstacle from the input, and no input obstacle disappears
        /// unless a nearer one shares its sector.
        #[test]
        fn resampling_keeps_every_obstacle_or_a_nearer_one(
            d in proptest::collection::vec(prop_oneof![Just(SECTOR_UNKNOWN), 0u16..2000], 0..72),
            increment in prop_oneof![Just(5.0f32), 0.5f32..20.0, -20.0f32..-0.5],
            offset in -180.0f32..180.0,
        ) {
            let s = sectors(d.clone(), increment, offset);
            let r = resample(&s);
            prop_assert_eq!(r.distances_cm.len(), 72);
            for &v in &r.distances_cm {
                prop_assert!(v == SECTOR_UNKNOWN || v == 1201 || (20..=1200).contains(&v));
            }
            for (i, &cm) in d.iter().enumerate() {
                if (20..=1200).contains(&cm) {
                    let bearing = f64::from(offset) + i as f64 * f64::from(increment);
                    let k = ((bearing / 5.0).round().rem_euclid(72.0)) as usize % 72;
                    prop_assert!(r.distances_cm[k] <= cm, "sector {} lost {}", k, cm);
                }
            }
        }
    }
}
