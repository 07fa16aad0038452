//! Who is in control: the RC receiver and a ground station's MAVLink sticks, two sources with a
//! rule between them, and the ground station's link. Pure bookkeeping of what was heard when;
//! the commander asks it for the sticks to fly and for each loss.
//!
//! * **One ground station counts**: `MAV_GCS_SYSID` (ArduPilot 4.7's name for SYSID_MYGCS,
//!   default 255). Its HEARTBEATs and its MANUAL_CONTROL hold off the ground-station failsafe
//!   (ArduCopter treats MANUAL_CONTROL as a heartbeat "for failsafe purposes"); other systems'
//!   heartbeats do not, and their MANUAL_CONTROL is ignored and counted, as ArduPilot's
//!   `handle_manual_control` drops sticks not from its GCS.
//! * **The receiver wins while it is healthy** (heard within `FS_RC_TIMEOUT_S`, ArduPilot's
//!   `RC_FS_TIMEOUT`, 1 s) — PX4's `COM_RC_IN_MODE` "RC priority". With it gone, the ground
//!   station's sticks fly while they are fresh: within `RC_OVERRIDE_TIME` (ArduPilot's, 3 s).
//! * **Each source has its own loss**, and neither holds off the other's: the receiver's
//!   (`FS_THR_*`: heard once, silent for its timeout) whatever the MAVLink sticks do; the
//!   ground station's (`FS_GCS_*`: heard once, silent for `FS_GCS_TIMEOUT_S`) whatever the
//!   receiver does. Without a receiver ever heard, the MAVLink sticks timing out is the stick
//!   loss (ArduPilot's radio failsafe fires when overrides expire with no RC).
//!
//! Held by the tests at the end of this file, the proptest
//! `no_source_holds_off_another_sources_loss` among them.

use kestrel_proto::Time;
use kestrel_proto::messages::{ManualControl, StickSource};

use super::params::CommanderParams;

/// Ignored MANUAL_CONTROL is announced (STATUSTEXT) at most this often (s): a second joystick
/// at 50 Hz must not flood the downlink.
pub const IGNORED_NOTICE_S: f64 = 10.0;

/// The rule's parameters, from `CommanderParams` at each call (they are live).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PilotLimits {
    /// `MAV_GCS_SYSID`: the ground station in control.
    pub gcs_system_id: u8,
    /// `FS_RC_TIMEOUT_S`: the receiver is lost after this long without sticks (s).
    pub radio_timeout_s: f64,
    /// `RC_OVERRIDE_TIME`: MAVLink sticks older than this fly nothing (s).
    pub mavlink_timeout_s: f64,
    /// `FS_GCS_TIMEOUT_S`: the ground station is lost after this long unheard (s).
    pub gcs_timeout_s: f64,
}

impl PilotLimits {
    /// The limits `params` set now.
    pub fn of(params: &CommanderParams) -> PilotLimits {
        PilotLimits {
            gcs_system_id: params.gcs_system_id,
            radio_timeout_s: params.failsafe.manual_timeout_s,
            mavlink_timeout_s: params.failsafe.mavlink_sticks_timeout_s,
            gcs_timeout_s: params.failsafe.link_timeout_s,
        }
    }
}

/// What became of one [`ManualControl`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SticksHeard {
    Taken,
    /// MAVLink sticks from a system other than `MAV_GCS_SYSID`.
    NotOurGcs {
        system_id: u8,
    },
    /// A stick position that is not a number.
    NotFinite,
}

/// The sticks heard from each source, and when the ground station in control was last heard.
#[derive(Clone, Debug, Default)]
pub struct PilotInput {
    radio: Option<ManualControl>,
    mavlink: Option<ManualControl>,
    gcs_heard: Option<Time>,
    /// MANUAL_CONTROL from other systems, ignored.
    ignored_sticks: u64,
    /// GCS heartbeats from other systems: answered by the link, no data link for the failsafe.
    ignored_heartbeats: u64,
    /// When ignored sticks were last announced.
    ignored_noticed: Option<Time>,
}

impl PilotInput {
    /// Sticks from either source; positions are clamped to their ranges.
    pub fn on_sticks(&mut self, m: &ManualControl, limits: &PilotLimits) -> SticksHeard {
        if ![m.roll, m.pitch, m.yaw, m.throttle].iter().all(|v| v.is_finite()) {
            return SticksHeard::NotFinite;
        }
        let clamped = ManualControl {
            roll: m.roll.clamp(-1.0, 1.0),
            pitch: m.pitch.clamp(-1.0, 1.0),
            yaw: m.yaw.clamp(-1.0, 1.0),
            throttle: m.throttle.clamp(0.0, 1.0),
            ..*m
        };
        match m.source {
            StickSource::Radio => self.radio = Some(clamped),
            StickSource::Mavlink { system_id } if system_id == limits.gcs_system_id => {
                self.mavlink = Some(clamped);
                self.gcs_heard = Some(m.time);
            }
            StickSource::Mavlink { system_id } => {
                self.ignored_sticks += 1;
                return SticksHeard::NotOurGcs { system_id };
            }
        }
        SticksHeard::Taken
    }

    /// A ground station's HEARTBEAT from `system_id` at `now`: true when it is the one in
    /// control (and so refreshes the data link).
    pub fn on_heartbeat(&mut self, system_id: u8, now: Time, limits: &PilotLimits) -> bool {
        let ours = system_id == limits.gcs_system_id;
        if ours {
            self.gcs_heard = Some(now);
        } else {
            self.ignored_heartbeats += 1;
        }
        ours
    }

    /// The sticks to fly at `now`: the receiver's while it is healthy, else the ground
    /// station's while fresh, else none.
    pub fn sticks(&self, now: Time, limits: &PilotLimits) -> Option<&ManualControl> {
        let fresh = |m: &&ManualControl, timeout_s: f64| age_s(now, m.time) <= timeout_s;
        self.radio
            .as_ref()
            .filter(|m| fresh(m, limits.radio_timeout_s))
            .or_else(|| self.mavlink.as_ref().filter(|m| fresh(m, limits.mavlink_timeout_s)))
    }

    /// The receiver was heard and has been silent for longer than its timeout.
    pub fn radio_lost(&self, now: Time, limits: &PilotLimits) -> bool {
        self.radio.is_some_and(|m| age_s(now, m.time) > limits.radio_timeout_s)
    }

    /// The ground station's sticks were heard and are older than `RC_OVERRIDE_TIME`.
    pub fn mavlink_sticks_lost(&self, now: Time, limits: &PilotLimits) -> bool {
        self.mavlink.is_some_and(|m| age_s(now, m.time) > limits.mavlink_timeout_s)
    }

    /// The stick-loss failsafe's condition (`FS_THR_*`): the receiver's loss once one was
    /// heard, whatever MAVLink sticks do; without a receiver, the MAVLink sticks' timeout.
    pub fn sticks_lost(&self, now: Time, limits: &PilotLimits) -> bool {
        if self.radio.is_some() {
            self.radio_lost(now, limits)
        } else {
            self.mavlink_sticks_lost(now, limits)
        }
    }

    /// The ground-station failsafe's condition (`FS_GCS_*`): `MAV_GCS_SYSID` was heard and has
    /// been silent for longer than `FS_GCS_TIMEOUT_S`, whatever the receiver or other systems do.
    pub fn gcs_lost(&self, now: Time, limits: &PilotLimits) -> bool {
        self.gcs_heard.is_some_and(|t| age_s(now, t) > limits.gcs_timeout_s)
    }

    /// Whether any sticks were ever taken.
    pub fn heard_sticks(&self) -> bool {
        self.radio.is_some() || self.mavlink.is_some()
    }

    /// Age at `now` of the newest sticks taken (s), if any.
    pub fn sticks_age_s(&self, now: Time) -> Option<f64> {
        [self.radio, self.mavlink].iter().flatten().map(|m| age_s(now, m.time)).reduce(f64::min)
    }

    /// MANUAL_CONTROL ignored so far (not from `MAV_GCS_SYSID`).
    pub fn ignored_sticks(&self) -> u64 {
        self.ignored_sticks
    }

    /// Whether ignored sticks heard at `now` are to be announced: the first time, then at most
    /// every [`IGNORED_NOTICE_S`].
    pub fn ignored_notice_due(&mut self, now: Time) -> bool {
        let due = self.ignored_noticed.is_none_or(|t| age_s(now, t) >= IGNORED_NOTICE_S);
        if due {
            self.ignored_noticed = Some(now);
        }
        due
    }

    /// GCS heartbeats from other systems so far.
    pub fn ignored_heartbeats(&self) -> u64 {
        self.ignored_heartbeats
    }
}

/// Seconds from `then` to `now` (0 for a stamp in the future).
fn age_s(now: Time, then: Time) -> f64 {
    now.saturating_since(then).as_secs_f64()
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    const LIMITS: PilotLimits =
        PilotLimits { gcs_system_id: 255, radio_timeout_s: 1.0, mavlink_timeout_s: 3.0, gcs_timeout_s: 5.0 };

    fn at(s: f64) -> Time {
        Time::from_secs_f64(s)
    }

    fn sticks(s: f64, pitch: f64, source: StickSource) -> ManualControl {
        ManualControl { time: at(s), pitch, throttle: 0.5, source, ..ManualControl::default() }
    }

    const RADIO: StickSource = StickSource::Radio;
    const GCS: StickSource = StickSource::Mavlink { system_id: 255 };
    const OTHER: StickSource = StickSource::Mavlink { system_id: 254 };

    fn pitch(p: &PilotInput, s: f64) -> Option<f64> {
        p.sticks(at(s), &LIMITS).map(|m| m.pitch)
    }

    #[test]
    fn a_healthy_receiver_wins_over_the_ground_stations_sticks() {
        let mut p = PilotInput::default();
        for i in 0..50 {
            let t = f64::from(i) * 0.02;
            assert_eq!(p.on_sticks(&sticks(t, 1.0, RADIO), &LIMITS), SticksHeard::Taken);
            assert_eq!(p.on_sticks(&sticks(t + 0.01, -1.0, GCS), &LIMITS), SticksHeard::Taken);
            assert_eq!(pitch(&p, t + 0.015), Some(1.0), "the receiver flies at {t} s");
        }
    }

    #[test]
    fn with_the_receiver_lost_the_ground_stations_sticks_fly_until_their_own_timeout() {
        let mut p = PilotInput::default();
        p.on_sticks(&sticks(0.0, 1.0, RADIO), &LIMITS);
        p.on_sticks(&sticks(0.5, -1.0, GCS), &LIMITS);
        assert_eq!(pitch(&p, 1.0), Some(1.0), "receiver 1.0 s old: still healthy");
        assert!(!p.radio_lost(at(1.0), &LIMITS));
        assert_eq!(pitch(&p, 1.01), Some(-1.0), "receiver lost: the MAVLink sticks fly");
        assert!(p.radio_lost(at(1.01), &LIMITS));
        assert!(p.sticks_lost(at(1.01), &LIMITS), "live MAVLink sticks do not hide the receiver's loss");
        assert_eq!(pitch(&p, 3.5), Some(-1.0), "3.0 s old: within RC_OVERRIDE_TIME");
        assert_eq!(pitch(&p, 3.51), None, "stale MAVLink sticks fly nothing");
        assert!(p.mavlink_sticks_lost(at(3.51), &LIMITS));
        // The receiver back: it wins again at once.
        p.on_sticks(&sticks(4.0, 0.25, RADIO), &LIMITS);
        assert_eq!(pitch(&p, 4.0), Some(0.25));
        assert!(!p.sticks_lost(at(4.0), &LIMITS));
    }

    #[test]
    fn without_a_receiver_the_mavlink_sticks_timing_out_is_the_stick_loss() {
        let mut p = PilotInput::default();
        assert!(!p.sticks_lost(at(100.0), &LIMITS), "never heard: nothing to lose");
        p.on_sticks(&sticks(0.0, 1.0, GCS), &LIMITS);
        assert!(!p.sticks_lost(at(3.0), &LIMITS));
        assert!(p.sticks_lost(at(3.01), &LIMITS));
        assert!(!p.radio_lost(at(3.01), &LIMITS));
    }

    #[test]
    fn only_mav_gcs_sysid_counts_for_sticks_and_the_data_link() {
        let mut p = PilotInput::default();
        assert_eq!(p.on_sticks(&sticks(0.0, 1.0, OTHER), &LIMITS), SticksHeard::NotOurGcs { system_id: 254 });
        assert_eq!(pitch(&p, 0.0), None, "another system's sticks fly nothing");
        assert!(!p.heard_sticks());
        assert!(!p.on_heartbeat(254, at(0.0), &LIMITS));
        assert!(!p.gcs_lost(at(100.0), &LIMITS), "another system's heartbeat starts no data link");
        assert!(p.on_heartbeat(255, at(1.0), &LIMITS));
        // 254 keeps beating and sending sticks; 255 falls silent.
        for i in 2..=7 {
            p.on_heartbeat(254, at(f64::from(i)), &LIMITS);
            p.on_sticks(&sticks(f64::from(i), 1.0, OTHER), &LIMITS);
        }
        assert!(!p.gcs_lost(at(6.0), &LIMITS));
        assert!(p.gcs_lost(at(6.01), &LIMITS), "254 held off 255's loss");
        assert_eq!((p.ignored_sticks(), p.ignored_heartbeats()), (7, 7));
        assert!(p.ignored_notice_due(at(2.0)));
        assert!(!p.ignored_notice_due(at(11.9)), "at most one notice in IGNORED_NOTICE_S");
        assert!(p.ignored_notice_due(at(12.0)));
        // MAV_GCS_SYSID moved to 254: now its sticks fly.
        let limits = PilotLimits { gcs_system_id: 254, ..LIMITS };
        assert_eq!(p.on_sticks(&sticks(8.0, 1.0, OTHER), &limits), SticksHeard::Taken);
        assert_eq!(p.sticks(at(8.0), &limits).map(|m| m.pitch), Some(1.0));
    }

    #[test]
    fn the_ground_stations_sticks_count_as_its_heartbeat_and_the_receivers_do_not() {
        let mut p = PilotInput::default();
        p.on_sticks(&sticks(0.0, 0.0, GCS), &LIMITS);
        for i in 1..=20 {
            p.on_sticks(&sticks(f64::from(i) * 0.5, 0.0, RADIO), &LIMITS);
        }
        assert!(!p.gcs_lost(at(5.0), &LIMITS));
        assert!(p.gcs_lost(at(5.01), &LIMITS), "the receiver held off the ground station's loss");
    }

    #[test]
    fn sticks_are_clamped_and_non_finite_ones_refused() {
        let mut p = PilotInput::default();
        let wild =
            ManualControl { roll: 3.0, pitch: -7.0, yaw: 2.0, throttle: 1.5, ..sticks(0.0, 0.0, RADIO) };
        p.on_sticks(&wild, &LIMITS);
        let m = p.sticks(at(0.0), &LIMITS).copied().expect("taken");
        assert_eq!((m.roll, m.pitch, m.yaw, m.throttle), (1.0, -1.0, 1.0, 1.0));
        let nan = ManualControl { throttle: f64::NAN, ..sticks(0.5, 0.0, RADIO) };
        assert_eq!(p.on_sticks(&nan, &LIMITS), SticksHeard::NotFinite);
        assert_eq!(p.sticks(at(0.5), &LIMITS).map(|m| m.throttle), Some(1.0), "the last good ones stay");
        assert_eq!(p.sticks_age_s(at(0.5)), Some(0.5));
    }

    /// One event of a random history: a source heard at a time, or nothing.
    #[derive(Clone, Copy, Debug)]
    enum Event {
        Radio,
        Gcs,
        OtherSticks,
        GcsHeartbeat,
        OtherHeartbeat,
    }

    fn event() -> impl Strategy<Value = Event> {
        prop_oneof![
            Just(Event::Radio),
            Just(Event::Gcs),
            Just(Event::OtherSticks),
            Just(Event::GcsHeartbeat),
            Just(Event::OtherHeartbeat),
        ]
    }

    proptest! {
        /// Whatever the other sources do, each loss follows from its own source's history
        /// alone: the receiver's from when it was last heard, the ground station's from when
        /// `MAV_GCS_SYSID` last spoke (heartbeat or sticks), and the receiver wins whenever it
        /// is fresh.
        #[test]
        fn no_source_holds_off_another_sources_loss(
            history in proptest::collection::vec((event(), 0u64..2_000_000), 0..60),
            check_after_us in 0u64..10_000_000,
        ) {
            let mut p = PilotInput::default();
            let mut t = 0u64;
            let (mut radio_at, mut gcs_at, mut mavlink_at) = (None, None, None);
            for (e, dt) in history {
                t += dt;
                let now = Time::from_micros(t);
                let s = |source| ManualControl { time: now, throttle: 0.5, source, ..ManualControl::default() };
                match e {
                    Event::Radio => {
                        p.on_sticks(&s(RADIO), &LIMITS);
                        radio_at = Some(t);
                    }
                    Event::Gcs => {
                        p.on_sticks(&s(GCS), &LIMITS);
                        gcs_at = Some(t);
                        mavlink_at = Some(t);
                    }
                    Event::OtherSticks => {
                        prop_assert_eq!(p.on_sticks(&s(OTHER), &LIMITS), SticksHeard::NotOurGcs { system_id: 254 });
                    }
                    Event::GcsHeartbeat => {
                        p.on_heartbeat(255, now, &LIMITS);
                        gcs_at = Some(t);
                    }
                    Event::OtherHeartbeat => {
                        p.on_heartbeat(254, now, &LIMITS);
                    }
                }
            }
            let now_us = t + check_after_us;
            let now = Time::from_micros(now_us);
            let older = |at: Option<u64>, timeout_s: f64| {
                at.is_some_and(|a| (now_us - a) as f64 / 1e6 > timeout_s)
            };
            prop_assert_eq!(p.radio_lost(now, &LIMITS), older(radio_at, LIMITS.radio_timeout_s));
            prop_assert_eq!(p.gcs_lost(now, &LIMITS), older(gcs_at, LIMITS.gcs_timeout_s));
            let expected_sticks_lost = if radio_at.is_some() {
                older(radio_at, LIMITS.radio_timeout_s)
            } else {
                older(mavlink_at, LIMITS.mavlink_timeout_s)
            };
            prop_assert_eq!(p.sticks_lost(now, &LIMITS), expected_sticks_lost);
            let radio_fresh = radio_at.is_some() && !older(radio_at, LIMITS.radio_timeout_s);
            let source = p.sticks(now, &LIMITS).map(|m| m.source);
            if radio_fresh {
                prop_assert_eq!(source, Some(RADIO));
            } else if mavlink_at.is_some() && !older(mavlink_at, LIMITS.mavlink_timeout_s) {
                prop_assert_eq!(source, Some(GCS));
            } else {
                prop_assert_eq!(source, None);
            }
        }
    }
}
