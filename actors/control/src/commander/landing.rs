//! Whether the vehicle is on the ground, in the air or landing, and what ends a flight on the
//! ground: the land detector in the landing modes, ground contact outside them (still for a
//! while although the setpoint asks to go down: a waypoint below the ground, a pilot who landed
//! in POSHOLD; PX4's and ArduPilot's detectors do not depend on the mode either), and
//! ArduCopter's `DISARM_DELAY` for a vehicle armed on the ground that never takes off.

use kestrel_proto::Time;
use kestrel_proto::messages::{FlightMode, LandedState, NavState};

use super::arming::{LOW_THROTTLE, needs_sticks};
use super::modes::RtlPhase;
use super::{Commander, LandDetector};

/// Height above home at which the vehicle counts as airborne (m).
const AIRBORNE_HEIGHT_M: f64 = 0.5;

/// What ended the flight on the ground this update.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Touchdown {
    /// The land detector, in a landing mode.
    Landed,
    /// Ground contact outside a landing mode.
    GroundContact,
}

/// The landed state and the detectors that change it.
#[derive(Debug)]
pub(crate) struct Landing {
    state: LandedState,
    /// The land detector of the landing modes (LAND, RTL's and AUTO's landings).
    detector: LandDetector,
    /// The land detector outside the landing modes, while a descent is demanded.
    ground_contact: LandDetector,
    /// The last setpoint asked for a descent the vehicle should be making.
    descent_demanded: bool,
    /// Armed and on the ground since then without a take-off (`disarm_delay_s`).
    idle_since: Option<Time>,
}

impl Default for Landing {
    fn default() -> Landing {
        Landing {
            state: LandedState::OnGround,
            detector: LandDetector::default(),
            ground_contact: LandDetector::default(),
            descent_demanded: false,
            idle_since: None,
        }
    }
}

impl Landing {
    pub fn state(&self) -> LandedState {
        self.state
    }

    pub fn on_ground(&self) -> bool {
        self.state == LandedState::OnGround
    }

    /// Armed or disarmed: on the ground, and no idle time counted.
    pub fn on_arming_change(&mut self, armed: bool) {
        self.state = LandedState::OnGround;
        if !armed {
            self.idle_since = None;
        }
    }

    /// A new mode: a landing starts its detection over.
    pub fn on_mode_change(&mut self) {
        self.detector.reset();
    }

    pub fn set_descent_demanded(&mut self, demanded: bool) {
        self.descent_demanded = demanded;
    }

    /// Whether the vehicle, `idle` (armed on the ground with the throttle low), has been so
    /// for `delay_s` (0 or less: never).
    pub fn idle_for(&mut self, now: Time, idle: bool, delay_s: f64) -> bool {
        if !idle || delay_s <= 0.0 {
            self.idle_since = None;
            return false;
        }
        let since = *self.idle_since.get_or_insert(now);
        now.saturating_since(since).as_secs_f64() >= delay_s
    }

    /// Follows the flight while armed: airborne past [`AIRBORNE_HEIGHT_M`] above home
    /// (`height_m`), landing while `landing_mode`, and a touchdown once a detector says so on
    /// `fresh` states (a frozen state's velocity says nothing about the ground). The caller
    /// ends the flight on a touchdown ([`Landing::touched_down`]).
    pub fn track(
        &mut self,
        now: Time,
        height_m: f64,
        landing_mode: bool,
        fresh: Option<&NavState>,
        detect_s: f64,
    ) -> Option<Touchdown> {
        let still = |detector: &mut LandDetector, n: &NavState| {
            let (valid, down) = (n.valid.ground_speed_observed(), n.position_ned_m[2]);
            detector.update(now, &n.velocity_ned_m_s, down, valid, detect_s)
        };
        match self.state {
            LandedState::OnGround if height_m > AIRBORNE_HEIGHT_M => self.state = LandedState::InAir,
            LandedState::InAir if landing_mode => {
                self.state = LandedState::Landing;
                self.detector.reset();
            }
            LandedState::Landing if !landing_mode => self.state = LandedState::InAir,
            LandedState::InAir if !landing_mode => {
                let touching =
                    self.descent_demanded && fresh.is_some_and(|n| still(&mut self.ground_contact, n));
                if !self.descent_demanded || fresh.is_none() {
                    self.ground_contact.reset();
                }
                if touching {
                    return Some(Touchdown::GroundContact);
                }
            }
            // A landing mode entered before the vehicle ever rose past the airborne height (LAND
            // sent at once after a take-off was accepted): it is already down, and the detector
            // must still end the flight, or it would idle armed on the ground for ever.
            LandedState::OnGround | LandedState::Landing if landing_mode && fresh.is_none() => {
                // The stillness timer starts over once NavStates are fresh again.
                self.detector.reset();
            }
            LandedState::OnGround | LandedState::Landing
                if landing_mode && fresh.is_some_and(|n| still(&mut self.detector, n)) =>
            {
                return Some(Touchdown::Landed);
            }
            _ => {}
        }
        None
    }

    /// A detector tripped: on the ground.
    pub fn touched_down(&mut self) {
        self.state = LandedState::OnGround;
        self.ground_contact.reset();
    }
}

impl Commander {
    pub(super) fn track_landed(&mut self, now: Time) {
        let Some(nav) = self.nav.latest().cloned() else { return };
        if !self.armed {
            self.landing.on_arming_change(false);
            return;
        }
        let landing_mode = self.is_landing();
        let fresh = self.fresh_nav(now).cloned();
        let height_m = self.home.height_m(&nav);
        match self.landing.track(now, height_m, landing_mode, fresh.as_ref(), self.params.land_detect_s) {
            Some(Touchdown::GroundContact) => {
                tracing::warn!(mode = ?self.mode, "on the ground outside a landing: disarming");
                self.announce(format!("{:?}: ground contact, landed", self.mode));
                self.touched_down();
            }
            Some(Touchdown::Landed) => {
                if let Some(runner) = &mut self.mission.runner
                    && self.mode == FlightMode::Auto
                {
                    runner.landed();
                }
                self.touched_down();
            }
            None => {}
        }
    }

    /// Armed on the ground for `disarm_delay_s` without taking off: disarm (ArduCopter's
    /// `DISARM_DELAY`). A pilot's throttle above low in a stick mode restarts the wait.
    pub(super) fn disarm_if_idle(&mut self, now: Time) {
        let throttle_up =
            needs_sticks(self.mode) && self.sticks(now).is_some_and(|m| m.throttle > LOW_THROTTLE);
        let idle = self.armed && self.landing.on_ground() && !throttle_up;
        if self.landing.idle_for(now, idle, self.params.disarm_delay_s) {
            let why = format!("no take-off within DISARM_DELAY ({} s)", self.params.disarm_delay_s);
            self.announce(format!("disarmed: {why}"));
            self.disarm(&why);
        }
    }

    /// The land detector tripped: on the ground, the mission's progress kept, disarmed.
    fn touched_down(&mut self) {
        self.landing.touched_down();
        self.mission.keep_progress();
        self.disarm("landed");
    }

    fn is_landing(&self) -> bool {
        let landing = match self.mode {
            FlightMode::Land => true,
            FlightMode::ReturnToLaunch => self.latched.rtl == RtlPhase::Land,
            FlightMode::Auto => self.latched.hold.landing,
            _ => false,
        };
        // Holding above an obstacle's top while moving off it is no descent: the land detector
        // would take the stillness for the ground.
        landing && !self.vertical.landing_search.searching()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commander::tests::nav;

    fn still(t_s: f64, down_m: f64) -> NavState {
        nav(Time::from_secs_f64(t_s), down_m, true)
    }

    #[test]
    fn airborne_past_half_a_metre_then_landing_in_a_landing_mode_and_back() {
        let mut l = Landing::default();
        let t = Time::from_secs_f64(1.0);
        assert_eq!(l.track(t, 0.4, false, None, 1.0), None);
        assert!(l.on_ground());
        l.track(t, 0.6, false, None, 1.0);
        assert_eq!(l.state(), LandedState::InAir);
        l.track(t, 5.0, true, None, 1.0);
        assert_eq!(l.state(), LandedState::Landing);
        l.track(t, 5.0, false, None, 1.0);
        assert_eq!(l.state(), LandedState::InAir);
    }

    #[test]
    fn a_landing_touches_down_once_still_for_the_detection_time_on_fresh_states_only() {
        let mut l = Landing { state: LandedState::Landing, ..Landing::default() };
        assert_eq!(l.track(Time::from_secs_f64(1.0), 0.0, true, Some(&still(1.0, 0.0)), 1.0), None);
        assert_eq!(l.track(Time::from_secs_f64(1.5), 0.0, true, None, 1.0), None, "stale: starts over");
        assert_eq!(l.track(Time::from_secs_f64(2.0), 0.0, true, Some(&still(2.0, 0.0)), 1.0), None);
        let down = l.track(Time::from_secs_f64(3.0), 0.0, true, Some(&still(3.0, 0.0)), 1.0);
        assert_eq!(down, Some(Touchdown::Landed));
        l.touched_down();
        assert!(l.on_ground());
    }

    #[test]
    fn ground_contact_outside_a_landing_needs_a_demanded_descent() {
        let mut l = Landing { state: LandedState::InAir, ..Landing::default() };
        for t in [1.0, 2.0, 3.0] {
            let n = still(t, -3.0);
            assert_eq!(l.track(Time::from_secs_f64(t), 3.0, false, Some(&n), 1.0), None, "no descent asked");
        }
        l.set_descent_demanded(true);
        assert_eq!(l.track(Time::from_secs_f64(4.0), 3.0, false, Some(&still(4.0, -3.0)), 1.0), None);
        let touch = l.track(Time::from_secs_f64(5.0), 3.0, false, Some(&still(5.0, -3.0)), 1.0);
        assert_eq!(touch, Some(Touchdown::GroundContact));
    }

    #[test]
    fn idle_counts_while_idle_and_a_delay_of_zero_never_fires() {
        let mut l = Landing::default();
        let t = Time::from_secs_f64;
        assert!(!l.idle_for(t(1.0), true, 10.0));
        assert!(!l.idle_for(t(10.9), true, 10.0));
        assert!(l.idle_for(t(11.0), true, 10.0));
        assert!(!l.idle_for(t(12.0), false, 10.0), "throttle up");
        assert!(!l.idle_for(t(21.0), true, 10.0), "counted afresh");
        assert!(!l.idle_for(t(100.0), true, 0.0));
        l.idle_for(t(200.0), true, 10.0);
        l.on_arming_change(false);
        assert!(!l.idle_for(t(205.0), true, 10.0), "a disarm forgets it");
    }
}
