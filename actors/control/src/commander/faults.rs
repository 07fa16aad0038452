//! What fails and what the commander does about it: the failsafe causes judged every update
//! (`FailsafeMonitor` keeps them and their log), a flight-critical actor's failure, the motor
//! check, and the strongest action applied so far this flight. An action is applied once, when
//! it is stronger than the one before (PX4's precedence: warn < hold < RTL < land < disarm); the
//! pilot may then only switch to LAND while it is RTL or stronger (`arming::mode_allowed`), but
//! for a geofence breach, which the pilot may fly out of (`Geofence::manual_recovery_start`). On
//! the ground, an RTL or a landing disarms.

use kestrel_proto::Time;
use kestrel_proto::messages::{FailsafeAction, FailsafeCause, FlightMode, LandedState, NavState};
use nalgebra::Vector3;

use super::arming::needs_position;
use super::geofence::GIVE_UP_M;
use super::pilot_input::PilotLimits;
use super::{Commander, FailsafeMonitor, MotorCheck, flown_from_sticks};

/// The failures watched for and the failsafe they started.
#[derive(Debug)]
pub(crate) struct Faults {
    /// The active failsafe causes and every one that fired while armed.
    pub monitor: FailsafeMonitor,
    /// ESC telemetry against the motor commands: a motor that stopped.
    pub motors: MotorCheck,
    /// The strongest action applied since the causes were last all clear.
    applied: Option<FailsafeAction>,
    /// A flight-critical actor failed (the supervisor said so) since arming.
    critical_actor_failed: bool,
}

impl Faults {
    pub fn new(motors: MotorCheck) -> Faults {
        Faults { monitor: FailsafeMonitor::default(), motors, applied: None, critical_actor_failed: false }
    }

    /// A new flight: no cause, no action, every actor and motor healthy again.
    pub fn on_arming(&mut self) {
        self.monitor.clear();
        self.applied = None;
        self.critical_actor_failed = false;
        self.motors.reset();
    }

    /// The supervisor reported a flight-critical actor failed.
    pub fn on_critical_actor_failed(&mut self) {
        self.critical_actor_failed = true;
    }

    pub fn critical_actor_failed(&self) -> bool {
        self.critical_actor_failed
    }

    /// A motor stopped and the others cannot hold every axis.
    pub fn motor_failed(&self) -> bool {
        self.motors.failed().is_some() && !self.motors.others_hold_all_axes()
    }

    /// The action to apply now, if any: the strongest active one while `armed`, when it is
    /// stronger than the one applied before. With no cause active, the next one applies anew.
    pub fn escalation(&mut self, armed: bool) -> Option<FailsafeAction> {
        let Some(worst) = self.monitor.worst() else {
            self.applied = None;
            return None;
        };
        if !armed || self.applied.is_some_and(|a| a >= worst.action) {
            return None;
        }
        self.applied = Some(worst.action);
        Some(worst.action)
    }
}

impl Commander {
    /// Judges every failsafe cause at `now` and acts on the strongest action (PX4's
    /// precedence: warn < hold < RTL < land < disarm).
    pub(super) fn check_failsafes(&mut self, now: Time) {
        let fs = self.params.failsafe.clone();
        let armed = self.armed;
        let nav = self.nav.latest().cloned();
        // The estimator's own freshness: the backup attitude lands the vehicle, it does not
        // stand in for the estimator's health.
        let fresh = self.nav.estimator_fresh(now, self.params.nav_timeout_s);
        let limits = PilotLimits::of(&self.params);
        // Each loss on its own source's silence (`pilot_input`): the receiver never holds off
        // the ground station's, nor MAVLink sticks the receiver's.
        let link_lost = self.pilot.gcs_lost(now, &limits);
        let battery = self.battery.failsafes(now, armed, &fs);
        let nav_stale = self.nav.stale_for(now, armed, fresh, fs.nav_stale_s);
        let unhealthy = nav.as_ref().is_some_and(|n| {
            fresh && (!n.valid.attitude || (needs_position(self.mode) && !n.valid.horizontal_position))
        });
        let avoidance_lost = self.avoidance.silent_for_s(now).is_some_and(|s| s > fs.avoidance_lost_s);
        let sticks_lost = flown_from_sticks(self.mode) && self.pilot.sticks_lost(now, &limits);
        let fence_action = self.judge_fence(now, nav.as_ref(), fs.geofence_action);
        let critical_actor_failed = self.faults.critical_actor_failed();
        let motor_failed = self.faults.motor_failed();
        let m = &mut self.faults.monitor;
        m.set(now, FailsafeCause::DataLinkLost, armed && link_lost, fs.link_action);
        m.set(now, FailsafeCause::BatteryLow, battery.low, fs.battery_low_action);
        m.set(now, FailsafeCause::BatteryCritical, battery.critical, fs.battery_critical_action);
        m.set(
            now,
            FailsafeCause::GeofenceBreach,
            fence_action.is_some(),
            fence_action.unwrap_or(fs.geofence_action),
        );
        m.set(now, FailsafeCause::EstimatorUnhealthy, armed && unhealthy, fs.estimator_action);
        m.set(now, FailsafeCause::NavStateStale, nav_stale, FailsafeAction::Land);
        m.set(
            now,
            FailsafeCause::CriticalActorFailed,
            armed && critical_actor_failed,
            fs.critical_actor_action,
        );
        m.set(now, FailsafeCause::ManualControlLost, armed && sticks_lost, fs.manual_action);
        m.set(now, FailsafeCause::AvoidanceLost, armed && avoidance_lost, fs.avoidance_action);
        m.set(now, FailsafeCause::MotorFailure, armed && motor_failed, fs.motor_failure_action);
        self.apply_failsafe(now);
    }

    /// The geofence's judgement at `now` (`Geofence::update`): the action its breach takes, or
    /// `None` inside (or off, or disarmed). An RTL more than `GIVE_UP_M` beyond the ceiling or
    /// the circle lands instead, as ArduCopter's `fence_check` does. A breach ending is
    /// announced ("Fence breach cleared", ArduCopter's notice). A new breach of a vehicle
    /// already breached (a backup fence crossed, `geofence::BACKUP_M`) takes the action again,
    /// as ArduCopter acts on every new breach: the first one goes through the failsafe monitor
    /// like any cause.
    fn judge_fence(
        &mut self,
        now: Time,
        nav: Option<&NavState>,
        action: FailsafeAction,
    ) -> Option<FailsafeAction> {
        let landing = self.mode == FlightMode::Land || self.landing.state() != LandedState::InAir;
        let home = nav.map_or_else(Vector3::zeros, |n| self.home.or_here(n));
        let before = self.geofence.status().breaches;
        let check = self.geofence.update(now, nav, &home, &self.params.geofence, self.armed, landing);
        if check.breaches == 0 {
            if before != 0 && self.armed {
                self.announce("Fence breach cleared".to_owned());
            }
            return None;
        }
        let far = nav.is_some_and(|n| {
            let p = Vector3::from(n.position_ned_m);
            self.geofence.breach_distance(&p, &home, &self.params.geofence) > GIVE_UP_M
        });
        let action =
            if far && action == FailsafeAction::ReturnToLaunch { FailsafeAction::Land } else { action };
        let stronger_elsewhere = self
            .faults
            .monitor
            .worst_except(FailsafeCause::GeofenceBreach)
            .is_some_and(|f| f.action > action);
        if check.new != 0
            && before != 0
            && self.faults.monitor.is_active(FailsafeCause::GeofenceBreach)
            && !stronger_elsewhere
        {
            tracing::warn!(breaches = check.breaches, ?action, "geofence breached again");
            self.act(now, action);
        }
        Some(action)
    }

    fn apply_failsafe(&mut self, now: Time) {
        let Some(action) = self.faults.escalation(self.armed) else { return };
        self.act(now, action);
    }

    /// Takes a failsafe's `action` now. A mode it changes starts the geofence's manual
    /// recovery while breached, as every mode change of ArduCopter's does (`Copter::set_mode`;
    /// its SITL says "Manual recovery started" right after a fence's own RTL): no new breach
    /// counts, nor does the breach clear, for the next 10 s.
    fn act(&mut self, now: Time, action: FailsafeAction) {
        let before = self.mode;
        self.take(now, action);
        if self.armed && self.mode != before {
            self.geofence.manual_recovery_start(now);
        }
    }

    fn take(&mut self, now: Time, action: FailsafeAction) {
        let on_ground = self.landing.on_ground();
        let position_ok = self.mode_allowed_ignoring_failsafe(now, FlightMode::ReturnToLaunch);
        match action {
            FailsafeAction::Warn => {}
            FailsafeAction::Disarm => self.disarm("failsafe"),
            FailsafeAction::ReturnToLaunch | FailsafeAction::Land if on_ground => {
                self.disarm("failsafe on the ground")
            }
            FailsafeAction::Hold => {
                let mode = if position_ok { FlightMode::PosHold } else { FlightMode::AltHold };
                self.enter(mode);
            }
            FailsafeAction::ReturnToLaunch if position_ok && self.home.ned().is_some() => {
                if self.mode != FlightMode::ReturnToLaunch {
                    self.enter(FlightMode::ReturnToLaunch);
                }
            }
            FailsafeAction::ReturnToLaunch | FailsafeAction::Land => {
                if self.mode != FlightMode::Land {
                    self.enter(FlightMode::Land);
                }
            }
        }
    }

    pub(super) fn mode_allowed_ignoring_failsafe(&self, now: Time, mode: FlightMode) -> bool {
        let nav = self.fresh_nav(now);
        !needs_position(mode)
            || nav.is_some_and(|n| {
                n.valid.horizontal_position && n.valid.vertical_position && n.origin.is_some()
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commander::params::FailsafeParams;

    fn faults() -> Faults {
        Faults::new(MotorCheck::new(FailsafeParams::default().motor_failure).expect("valid"))
    }

    #[test]
    fn an_action_is_applied_once_and_only_a_stronger_one_escalates() {
        let (mut f, t) = (faults(), Time(1000));
        assert_eq!(f.escalation(true), None, "nothing active");
        f.monitor.set(t, FailsafeCause::DataLinkLost, true, FailsafeAction::ReturnToLaunch);
        assert_eq!(f.escalation(true), Some(FailsafeAction::ReturnToLaunch));
        assert_eq!(f.escalation(true), None, "applied already");
        f.monitor.set(t, FailsafeCause::GeofenceBreach, true, FailsafeAction::Hold);
        assert_eq!(f.escalation(true), None, "weaker");
        f.monitor.set(t, FailsafeCause::BatteryCritical, true, FailsafeAction::Land);
        assert_eq!(f.escalation(true), Some(FailsafeAction::Land), "stronger");
    }

    #[test]
    fn disarmed_nothing_is_applied_and_all_clear_starts_over() {
        let (mut f, t) = (faults(), Time(1000));
        f.monitor.set(t, FailsafeCause::DataLinkLost, true, FailsafeAction::ReturnToLaunch);
        assert_eq!(f.escalation(false), None);
        assert_eq!(f.escalation(true), Some(FailsafeAction::ReturnToLaunch));
        f.monitor.set(t, FailsafeCause::DataLinkLost, false, FailsafeAction::ReturnToLaunch);
        assert_eq!(f.escalation(true), None);
        f.monitor.set(t, FailsafeCause::DataLinkLost, true, FailsafeAction::ReturnToLaunch);
        assert_eq!(f.escalation(true), Some(FailsafeAction::ReturnToLaunch), "applies anew");
    }

    #[test]
    fn arming_clears_a_failed_actor_and_the_causes() {
        let mut f = faults();
        f.on_critical_actor_failed();
        f.monitor.set(Time(1000), FailsafeCause::CriticalActorFailed, true, FailsafeAction::Land);
        assert!(f.critical_actor_failed());
        f.on_arming();
        assert!(!f.critical_actor_failed());
        assert!(f.monitor.worst().is_none());
        assert!(!f.motor_failed());
    }
}
