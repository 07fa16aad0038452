//! Pre-arm checks and what each mode needs before it may be entered.

use kestrel_proto::Time;
use kestrel_proto::messages::{FailsafeAction, FlightMode, LandedState};
use nalgebra::Vector3;

use super::pilot_input::PilotLimits;
use super::{Commander, flown_from_sticks};

/// Why a command or mode change was refused (reported in `VehicleStatus::last_refusal`).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct Refusal(pub String);

pub(crate) fn refuse<T>(reason: impl Into<String>) -> Result<T, Refusal> {
    Err(Refusal(reason.into()))
}

/// Modes that fly on the estimator's horizontal position.
pub fn needs_position(mode: FlightMode) -> bool {
    matches!(
        mode,
        FlightMode::PosHold
            | FlightMode::Guided
            | FlightMode::Auto
            | FlightMode::Takeoff
            | FlightMode::ReturnToLaunch
            | FlightMode::Circle
            | FlightMode::Brake
            | FlightMode::Follow
    )
}

/// Modes flown from the sticks alone, with no position to hold without them: entered and armed
/// only on live sticks (`Commander::sticks`), and armed only with the throttle low. POSHOLD,
/// also flown from the sticks, holds its position without them and may arm on none; with live
/// sticks it must not be asked to climb (`prearm`).
pub fn needs_sticks(mode: FlightMode) -> bool {
    matches!(mode, FlightMode::Stabilize | FlightMode::Acro | FlightMode::AltHold)
}

/// How long a battery report stays valid for the pre-arm check (s).
const BATTERY_FRESH_S: f64 = 2.0;
/// Largest tilt at which the vehicle may arm (rad): it must stand on its legs.
const MAX_ARM_TILT_RAD: f64 = 0.5;
/// Throttle below which the sticks count as "low" for arming.
pub(crate) const LOW_THROTTLE: f64 = 0.1;

impl Commander {
    pub(super) fn arm(&mut self, now: Time) -> Result<(), Refusal> {
        if self.armed {
            // Already armed is done, as in ArduPilot and PX4: a ground station whose ACK was lost
            // retries, and must hear ACCEPTED, not a refusal of what it asked for.
            return Ok(());
        }
        self.prearm(now)?;
        let nav = self.fresh_nav(now).cloned();
        self.armed = true;
        self.home.on_arming(nav.map(|n| Vector3::from(n.position_ned_m)));
        self.landing.on_arming_change(true);
        self.faults.on_arming();
        self.enter(self.mode);
        if self.mode == FlightMode::Auto {
            self.mission.start_run();
        }
        tracing::info!(mode = ?self.mode, "armed");
        Ok(())
    }

    pub(super) fn disarm(&mut self, why: &str) {
        if self.armed {
            tracing::info!(why, "disarmed");
        }
        self.armed = false;
        self.landing.on_arming_change(false);
        self.latched.flip = None;
        self.vertical.reset_landing_search();
        // As PX4: failsafes belong to a flight. Latched causes (battery, estimator, critical
        // actor) would otherwise refuse every later arming; the pre-arm checks judge afresh.
        self.faults.monitor.clear();
    }

    /// Whether `mode` can be flown with what the commander knows now.
    pub(crate) fn mode_allowed(&self, now: Time, mode: FlightMode) -> Result<(), Refusal> {
        // A geofence breach does not hold the pilot in its action: a mode asked for while
        // breached starts a manual recovery (`Geofence::manual_recovery_start`), as
        // ArduCopter's (its `FENCE_OPTIONS` bit 0, off for a copter, would refuse it).
        if let Some(f) = self
            .faults
            .monitor
            .worst_except(kestrel_proto::messages::FailsafeCause::GeofenceBreach)
            .filter(|f| f.action >= kestrel_proto::messages::FailsafeAction::ReturnToLaunch)
            && self.armed
            && mode != FlightMode::Land
            && mode != self.mode
        {
            return refuse(format!("{mode:?} refused: failsafe {:?} ({:?}) is active", f.action, f.cause));
        }
        let nav = self.fresh_nav(now);
        if needs_position(mode) {
            let Some(nav) = nav else { return refuse(format!("{mode:?} needs a fresh navigation state")) };
            if !(nav.valid.horizontal_position && nav.valid.vertical_position && nav.origin.is_some()) {
                return refuse(format!("{mode:?} needs a position estimate (GPS fix)"));
            }
        }
        if mode == FlightMode::AltHold && !nav.is_some_and(|n| n.valid.vertical_position) {
            return refuse("AltHold needs a height estimate");
        }
        if mode == FlightMode::Follow && !self.params.follow.enabled {
            // ArduCopter's `ModeFollow::init` says exactly this and refuses the mode.
            return refuse("Set FOLL_ENABLE = 1");
        }
        if mode == FlightMode::Auto && self.mission.uploaded.is_none() {
            return refuse("Auto needs a mission");
        }
        if needs_sticks(mode) && self.sticks(now).is_none() {
            return refuse(format!("{mode:?} needs manual control input"));
        }
        if mode == FlightMode::Auto
            && let Some(mission) = &self.mission.uploaded
        {
            self.mission_feasible(mission).map_err(|r| Refusal(format!("Auto refused: {r}")))?;
        }
        Ok(())
    }

    /// The pre-arm checks, first failure first: the vehicle's own, then the mode's.
    pub(crate) fn prearm(&self, now: Time) -> Result<(), Refusal> {
        if self.armed {
            return refuse("already armed");
        }
        self.vehicle_ready(now)?;
        if matches!(
            self.mode,
            FlightMode::ReturnToLaunch
                | FlightMode::Land
                | FlightMode::Circle
                | FlightMode::Brake
                | FlightMode::Follow
        ) {
            // ArduCopter's RTL and LAND do not allow arming: the vehicle would take off only to
            // come straight back down, or sit armed waiting for the land detector. Nor do its
            // CIRCLE, BRAKE and FOLLOW (`allows_arming` false): they fly only once in the air.
            return refuse(format!("arming refused: not in {:?} (choose GUIDED, LOITER or AUTO)", self.mode));
        }
        self.sticks_ready(now)?;
        self.mode_allowed(now, self.mode).map_err(|r| Refusal(format!("arming refused: {r}")))?;
        Ok(())
    }

    /// The pilot's part of the pre-arm checks, each text within one STATUSTEXT (50 characters),
    /// in ArduCopter's words (`AP_Arming_Copter`'s
    /// "Throttle too high", "RC not found", "Radio failsafe on"): a mode flown from the sticks
    /// arms only on live ones with the throttle low — one MANUAL_CONTROL heard seconds ago is
    /// no pilot — and POSHOLD not with the throttle asking to climb; a receiver that was heard
    /// and is lost refuses every stick mode while its failsafe acts.
    fn sticks_ready(&self, now: Time) -> Result<(), Refusal> {
        let limits = PilotLimits::of(&self.params);
        let sticks = self.sticks(now);
        if needs_sticks(self.mode) {
            let Some(s) = sticks else {
                return match self.pilot.sticks_age_s(now) {
                    None => refuse(format!("Arm: RC not found ({:?} needs sticks)", self.mode)),
                    Some(age_s) => {
                        refuse(format!("Arm: {:?}: no manual control for {age_s:.1} s", self.mode))
                    }
                };
            };
            if s.throttle > LOW_THROTTLE {
                return refuse(format!("Arm: Throttle too high ({:.0} %)", s.throttle * 100.0));
            }
        }
        if self.mode == FlightMode::PosHold
            && sticks.is_some_and(|s| s.throttle > 0.5 + 0.5 * self.params.throttle_deadband)
        {
            return refuse("Arm: Throttle too high (POSHOLD would climb)");
        }
        if flown_from_sticks(self.mode)
            && self.pilot.radio_lost(now, &limits)
            && self.params.failsafe.manual_action != FailsafeAction::Warn
        {
            return refuse("Arm: Radio failsafe on (RC receiver lost)");
        }
        Ok(())
    }

    /// The checks of the vehicle itself, whatever the mode: what ArduPilot's pre-arm checks
    /// report in SYS_STATUS (`MAV_SYS_STATUS_PREARM_CHECK`, MAVSDK's `is_armable`); a ground
    /// station's arming switches to a mode that may arm first.
    pub(crate) fn vehicle_ready(&self, now: Time) -> Result<(), Refusal> {
        let Some(nav) = self.fresh_nav(now) else {
            return refuse("arming refused: no fresh navigation state");
        };
        if !nav.valid.attitude {
            return refuse("arming refused: attitude estimate not converged");
        }
        if self.tilt_rad(nav) > MAX_ARM_TILT_RAD {
            return refuse("arming refused: vehicle not level");
        }
        if self.landing.state() != LandedState::OnGround {
            return refuse("arming refused: not on the ground");
        }
        if self.params.require_battery {
            match self.battery.report() {
                Some(b) if now.saturating_since(b.time).as_secs_f64() <= BATTERY_FRESH_S => {
                    if b.remaining <= self.params.failsafe.battery_low {
                        return refuse(format!("arming refused: battery at {:.0} %", b.remaining * 100.0));
                    }
                }
                _ => return refuse("arming refused: no battery report"),
            }
        }
        if let Some(f) = self.faults.monitor.worst() {
            return refuse(format!("arming refused: failsafe {:?} active", f.cause));
        }
        // ArduPilot's pre-arm calibration checks; which steps are required is the calibration
        // actor's `required` (a graph without one requires none).
        if let Some(c) = &self.calibration {
            if let Some(step) = c.running {
                return refuse(format!("PreArm: {} calibration running", step.name()));
            }
            if let Some(step) = c.missing.first() {
                return refuse(step.prearm_text());
            }
        }
        if let Some(why) = self.geofence.pre_arm(&self.params.geofence) {
            return refuse(format!("PreArm: {why}"));
        }
        if self.geofence.enabled()
            && self.geofence.outside(nav, &self.home.or_here(nav), &self.params.geofence)
        {
            return refuse("arming refused: outside the geofence");
        }
        Ok(())
    }
}
