//! The commander: arming, flight modes, missions and failsafes — a pure state machine fed
//! with messages and asked, at its own pace, for the setpoint to fly and the status to report.
//!
//! Home is the NED position where the vehicle armed, unless a ground station set it
//! (MAV_CMD_DO_SET_HOME, see `home`): then it stays where it was put. Failsafes follow PX4's precedence
//! (warn < hold < RTL < land < disarm): the active cause with the strongest action decides,
//! its cause is reported in `VehicleStatus`, and while an RTL-or-stronger failsafe is active
//! the pilot may only switch to LAND (PX4 lets the pilot take over in some cases; we are
//! conservative here). On the ground, a failsafe of RTL or stronger disarms.
//!
//! Where to look: each piece of state is a struct in the file named after it, which changes it
//! and tests it; `impl Commander` blocks beside them join the pieces.
//! * what comes in: `commands` (a ground station's commands and missions), `pilot_input`
//!   (sticks, who is in control), `nav_source` (estimator or backup attitude), `battery`,
//!   `live_params`;
//! * what is flown: `modes` (each mode's setpoint, and what it latched), `guided` (GUIDED's
//!   target, the nose's aim), `mission` and `mission_runner`, `avoidance`, `vertical` and
//!   `vertical_limit` (the rangefinders), `crate::flip`;
//! * where: `home` (home and the NED frame), `rally` (rally points, and where RTL returns),
//!   `geofence`, `feasibility` (what may be flown to);
//! * what ends a flight or starts a failsafe: `arming`, `landing` and `land_detector`, `faults`
//!   (the causes and the action applied), `failsafe`, `failsafe_actions`, `motor_check`,
//!   `shutdown`;
//! * what is said: `announcements` (refusals and notices, as STATUSTEXT).

mod announcements;
mod arming;
mod avoidance;
mod battery;
mod brake;
mod circle;
mod commands;
mod failsafe;
mod failsafe_actions;
mod faults;
mod feasibility;
mod fence_zones;
mod follow;
mod geofence;
mod guided;
mod guided_setpoint;
mod home;
mod land_detector;
mod landing;
mod live_params;
mod mission;
mod mission_runner;
mod modes;
mod motor_check;
mod nav_source;
mod params;
mod pilot_input;
mod rally;
mod shutdown;
mod spline;
mod vertical;
mod vertical_limit;

use kestrel_proto::Time;
use kestrel_proto::attitude::{tilt_rad, unit_quaternion};
use kestrel_proto::messages::{
    ActuatorOutputs, AvoidanceCommand, BatteryStatus, CalibrationStatus, EscTelemetry, FlightMode,
    LandedState, ManualControl, NavState, ParamDecl, RangefinderSample, Setpoint, SetpointTarget,
    SupervisorEvent, SupervisorEventKind, VehicleStatus,
};
use nalgebra::{UnitQuaternion, Vector3};

pub use arming::{Refusal, needs_position, needs_sticks};
pub use avoidance::{cap_braking, frd_to_ned};
pub use brake::{BRAKE_DECEL_M_S2, Brake, BrakeTarget};
pub use circle::{Circle, CircleParams, CircleTarget};
pub use failsafe::{FailsafeMonitor, FailsafeRecord, HeldFor, NetHeldFor};
pub use follow::{
    FOLLOW_PARAMS, FollowAltitude, FollowParams, FollowPoint, FollowTracker, FollowYaw, NoTarget,
    OffsetFrame, Predicted, Report, TARGET_TIMEOUT_S,
};
pub use kestrel_proto::param_def::{ParamChange, ParamRefused};
pub use land_detector::LandDetector;
pub use mission_runner::{MissionRunner, MissionStep};
pub use motor_check::{COMMAND_STALE_S, MotorCheck};
pub use params::{CommanderParams, FailsafeParams, FeasibilityParams, GeofenceParams};
pub use pilot_input::{PilotInput, PilotLimits, SticksHeard};
pub use rally::RallyParams;
pub use vertical::VerticalParams;

use crate::error::InvalidParam;
use crate::position::yaw_of;
use modes::ModeLatches;

/// A height target this far below the vehicle (m), or a descent faster than this (m/s), is a
/// demand to go down: the position loop turns 1 m of error into a descent well above the land
/// detector's still threshold, so standing still against it means the ground is there. A
/// slower descent is followed too slowly to tell from standing (the detector's still speed is
/// 0.2 m/s): a vehicle stalled 3.4 m up in front of trunks, sinking at a few cm/s under the
/// avoider's small downward corrections, was disarmed as if on the ground (decision 0044).
const DESCENT_DEMAND_M: f64 = 1.0;
const DESCENT_DEMAND_M_S: f64 = 0.5;

/// The commander's state.
#[derive(Debug)]
pub struct Commander {
    params: CommanderParams,
    armed: bool,
    mode: FlightMode,
    /// The mode is still the one chosen at boot (GUIDED, which needs no sticks, so a ground
    /// station without a radio can arm): the first sticks heard while disarmed switch to
    /// STABILIZE, as a vehicle with a radio boots. A mode set by anyone ends the choice.
    boot_mode: bool,
    /// On the ground, in the air or landing, and the detectors that say so (`landing`).
    landing: landing::Landing,
    /// The state flown on, the estimator's or the backup attitude's, and the estimator's
    /// health (`nav_source`).
    nav: nav_source::NavSource,
    /// Home and the estimator's NED frame (`home`).
    home: home::Home,
    /// The geofence's switch, shapes and breaches (`geofence`).
    geofence: geofence::Geofence,
    /// The newest battery report and the voltage held under its thresholds (`battery`).
    battery: battery::Battery,
    /// The calibration's last word: required steps missing, one running (pre-arm).
    calibration: Option<CalibrationStatus>,
    /// The receiver's and the ground station's sticks and the ground station's link: who is in
    /// control (`pilot_input`).
    pilot: PilotInput,
    /// The uploaded mission, its run and a pause (`mission`).
    mission: mission::MissionState,
    /// The rally points a ground station uploaded (`rally`).
    rally: rally::Rally,
    /// What the current mode latched: held position, RTL's phase, a flip (`modes`).
    latched: ModeLatches,
    /// GUIDED's target, the nose's aim and the take-off height (`guided`).
    guided: guided::Guided,
    /// The failsafe causes, a failed actor or motor, and the action applied (`faults`).
    faults: faults::Faults,
    /// Refusals and notices for the status and its STATUSTEXT (`announcements`).
    announcements: announcements::Announcements,
    /// The time of the last `update`, for its time step.
    last_update: Option<Time>,
    /// The avoider's corrections and their freshness (`avoidance`).
    avoidance: avoidance::AvoidanceLoop,
    /// The rangefinders, a landing moving off an obstacle's top, and the vertical limit
    /// reported (`vertical_limit`).
    vertical: vertical_limit::VerticalLimit,
    /// Other systems' position reports and the one FOLLOW flies after (`follow`).
    follow: follow::FollowTracker,
}

impl Commander {
    pub fn new(params: CommanderParams) -> Result<Commander, InvalidParam> {
        params.validate()?;
        let motors = MotorCheck::new(params.failsafe.motor_failure)
            .map_err(|e| InvalidParam::new("failsafe.motor_failure", e.to_string()))?;
        Ok(Commander {
            guided: guided::Guided::new(params.takeoff_altitude_m),
            geofence: geofence::Geofence::new(params.geofence.enabled),
            params,
            armed: false,
            mode: FlightMode::Guided,
            boot_mode: true,
            landing: landing::Landing::default(),
            nav: nav_source::NavSource::default(),
            home: home::Home::default(),
            battery: battery::Battery::default(),
            calibration: None,
            pilot: PilotInput::default(),
            mission: mission::MissionState::default(),
            rally: rally::Rally::default(),
            latched: ModeLatches::default(),
            faults: faults::Faults::new(motors),
            announcements: announcements::Announcements::default(),
            last_update: None,
            avoidance: avoidance::AvoidanceLoop::default(),
            vertical: vertical_limit::VerticalLimit::default(),
            follow: follow::FollowTracker::default(),
        })
    }

    /// The parameters in use.
    pub fn params(&self) -> &CommanderParams {
        &self.params
    }

    /// A ground station changed parameter `name` (MAVLink name, see `live_params`): applied if
    /// it is one of the commander's and the result validates, otherwise the old value stays.
    pub fn on_param(&mut self, name: &str, value: f64) -> Result<ParamChange, ParamRefused> {
        let change = live_params::apply(&mut self.params, name, value)?;
        // FENCE_ENABLE is the switch too, as ArduCopter's parameter is.
        if change == ParamChange::Applied && name == "FENCE_ENABLE" {
            self.geofence.set_enabled(self.params.geofence.enabled);
        }
        // `apply` validated the whole set, the detector's part with it.
        self.faults
            .motors
            .set_params(self.params.failsafe.motor_failure)
            .map_err(|e| ParamRefused::Invalid { name: name.to_owned(), reason: e.to_string() })?;
        Ok(change)
    }

    /// The commander's live parameters with their current values, for the link (`param_decl`;
    /// `start` when the actor has just started).
    pub fn param_decl(&self, owner: &str, start: bool, now: Time) -> ParamDecl {
        let mut decl =
            kestrel_proto::param_def::declare(live_params::LIVE_PARAMS, &self.params, owner, start, now);
        // FENCE_TOTAL takes only its own value: an upload changes it, a PARAM_SET cannot.
        for p in decl.params.iter_mut().filter(|p| p.name == "FENCE_TOTAL") {
            (p.min, p.max) = (p.value, p.value);
        }
        let follow =
            kestrel_proto::param_def::declare(follow::FOLLOW_PARAMS, &self.params, owner, start, now);
        decl.params.extend(follow.params);
        decl
    }

    pub fn armed(&self) -> bool {
        self.armed
    }

    pub fn mode(&self) -> FlightMode {
        self.mode
    }

    pub fn landed(&self) -> LandedState {
        self.landing.state()
    }

    /// Home, NED from the estimator's origin (m); set at arming or by a ground station.
    pub fn home_ned(&self) -> Option<Vector3<f64>> {
        self.home.ned()
    }

    /// Every failsafe that fired while armed.
    pub fn failsafe_log(&self) -> &[FailsafeRecord] {
        self.faults.monitor.log()
    }

    /// A new navigation state (non-finite ones, and attitudes that are no rotation, are
    /// ignored: the loop rejects them too).
    pub fn on_nav(&mut self, nav: &NavState) {
        if self.nav.on_estimator(nav) {
            self.take_nav(nav);
        }
    }

    /// A state of the controller's backup attitude, published while the loop flies on it: taken
    /// in place of the estimator's while that is stale, so the modes, the landing and the land
    /// detector have an attitude, a height and a climb rate (no horizontal position). The
    /// switch is announced. The estimator's staleness stays a failsafe (`check_failsafes`).
    pub fn on_backup_nav(&mut self, nav: &NavState) {
        let Some(switched) = self.nav.on_backup(nav, self.params.nav_timeout_s) else { return };
        if switched {
            self.announce("EKF failed: backup attitude".to_owned());
        }
        self.take_nav(nav);
    }

    /// The state flown on is the backup attitude's.
    pub fn on_backup_attitude(&self) -> bool {
        self.nav.backup_flown()
    }

    fn take_nav(&mut self, nav: &NavState) {
        if let Some(frame) = self.home.on_origin(nav.origin) {
            self.geofence.place(&frame, &self.params.geofence.polygon);
        }
        self.nav.take(nav);
    }

    /// The motor commands the loop published, for the motor check.
    pub fn on_actuators(&mut self, outputs: &ActuatorOutputs) {
        self.faults.motors.on_actuators(outputs);
    }

    /// What the ESCs say the motors produce: a motor declared failed is announced (STATUSTEXT),
    /// shown in the status, left out of the allocation, and a failsafe where the others cannot
    /// hold every axis.
    pub fn on_esc_telemetry(&mut self, esc: &EscTelemetry) {
        if !self.armed {
            return;
        }
        if let Some(motor) = self.faults.motors.on_telemetry(esc) {
            let continues = self.faults.motors.others_hold_all_axes();
            tracing::warn!(motor = motor + 1, at = %esc.time, continues, "motor failure detected");
            let what = if continues { "flying on the others" } else { "cannot hold yaw" };
            self.announce(format!("Motor {} failure: {what}", motor + 1));
        }
    }

    /// The motor declared failed this flight (0-based), if any.
    pub fn failed_motor(&self) -> Option<usize> {
        self.faults.motors.failed()
    }

    pub fn on_battery(&mut self, battery: &BatteryStatus) {
        self.battery.on_report(battery);
    }

    /// The calibration's status, for the pre-arm check.
    pub fn on_calibration(&mut self, status: &CalibrationStatus) {
        self.calibration = Some(status.clone());
    }

    /// Sticks from the receiver or a ground station, arbitrated by `pilot_input`: the
    /// receiver wins while healthy, MAVLink sticks count only from `MAV_GCS_SYSID` (and also
    /// as its heartbeat), others are ignored with a STATUSTEXT at most every
    /// [`pilot_input::IGNORED_NOTICE_S`]. Non-finite sticks are ignored.
    pub fn on_manual(&mut self, manual: &ManualControl) {
        let limits = PilotLimits::of(&self.params);
        match self.pilot.on_sticks(manual, &limits) {
            SticksHeard::Taken if self.boot_mode && !self.armed => {
                tracing::info!("sticks heard: booting in Stabilize");
                self.boot_mode = false;
                self.enter(FlightMode::Stabilize);
            }
            SticksHeard::Taken => {}
            SticksHeard::NotOurGcs { system_id } => {
                if self.pilot.ignored_notice_due(manual.time) {
                    let ignored = self.pilot.ignored_sticks();
                    tracing::warn!(system_id, ignored, "MANUAL_CONTROL not from MAV_GCS_SYSID ignored");
                    // Within one STATUSTEXT (50 characters).
                    self.announce(format!(
                        "Sticks from sysid {system_id} ignored (MAV_GCS_SYSID {})",
                        limits.gcs_system_id
                    ));
                }
            }
            SticksHeard::NotFinite => tracing::debug!(source = ?manual.source, "non-finite sticks ignored"),
        }
    }

    /// A correction from the obstacle avoider: from the first one on, AUTO and GUIDED legs and
    /// the pilot's forward sticks in POSHOLD blend it in and hold when the stream goes stale
    /// (see `avoidance`). Non-finite ones are ignored.
    pub fn on_avoidance(&mut self, cmd: &AvoidanceCommand) {
        let joining = !self.avoidance.active();
        if !self.avoidance.on_command(cmd) {
            tracing::warn!("non-finite avoidance command ignored");
        } else if joining {
            // Once per run: from here a stale stream holds the legs, so whoever tests or flies
            // a loss of the vision side knows from when on it counts.
            tracing::info!("avoider in the loop: its corrections steer the legs");
        }
    }

    /// A reading of the up- or downward rangefinder (`vertical`); a bad one is logged and
    /// dropped, the last good one stays until it times out.
    pub fn on_rangefinder(&mut self, sample: &RangefinderSample) {
        if let Err(why) = self.vertical.on_sample(sample) {
            tracing::warn!(orientation = ?sample.orientation, %why, "rangefinder sample refused");
        }
    }

    /// Holding because the avoidance stream is stale.
    pub fn avoidance_holding(&self) -> bool {
        self.avoidance.active() && self.avoidance.state.is_some() && self.avoidance.holding
    }

    /// A failure report from the supervisor; a flight-critical actor's failure is a failsafe.
    pub fn on_supervisor(&mut self, event: &SupervisorEvent) {
        if event.critical && matches!(event.kind, SupervisorEventKind::Failed | SupervisorEventKind::GaveUp) {
            tracing::error!(actor = %event.actor, reason = %event.reason, "flight-critical actor failed");
            self.faults.on_critical_actor_failed();
        }
    }

    /// Records `text` as the newest refusal (or notice) for the status and its STATUSTEXT.
    pub(crate) fn announce(&mut self, text: String) {
        self.announcements.announce(text);
    }

    fn refused<T>(&mut self, result: Result<T, Refusal>) -> Result<T, Refusal> {
        if let Err(r) = &result {
            tracing::info!(reason = %r, "refused");
            self.announce(r.0.clone());
        }
        result
    }

    /// The pilot's sticks if they are fresh at `now` (`pilot_input`: the receiver's while it is
    /// healthy, else the ground station's): a MANUAL_CONTROL sent once, seconds ago, must not
    /// fly the vehicle.
    pub(crate) fn sticks(&self, now: Time) -> Option<&ManualControl> {
        self.pilot.sticks(now, &PilotLimits::of(&self.params))
    }

    /// The newest NavState if it is fresh at `now`.
    fn fresh_nav(&self, now: Time) -> Option<&NavState> {
        self.nav.fresh(now, self.params.nav_timeout_s)
    }

    fn tilt_rad(&self, nav: &NavState) -> f64 {
        tilt_rad(&attitude(nav))
    }

    /// Runs the state machine at `now` and returns the setpoint to fly.
    pub fn update(&mut self, now: Time) -> Setpoint {
        let dt_s = self.last_update.map_or(0.0, |t| now.saturating_since(t).as_secs_f64().min(0.1));
        self.last_update = Some(now);
        self.track_landed(now);
        self.disarm_if_idle(now);
        self.check_failsafes(now);
        self.vertical.begin_update();
        let mut target = if self.armed { self.fly(now, dt_s) } else { SetpointTarget::MotorsOff };
        self.vertical.hold_below_ceiling(now, self.nav.latest(), &mut target, &self.params.vertical);
        self.landing.set_descent_demanded(self.nav.latest().is_some_and(|n| descends(&target, n)));
        if self.armed && self.mode == FlightMode::Auto && self.mission.runner.is_some() {
            // The run has started from the item a ground station chose; later runs start over.
            self.mission.start = None;
        }
        let landing = self.armed && self.landing.state() == LandedState::Landing;
        let failed_motor = self.failed_motor_u8();
        Setpoint { time: now, armed: self.armed, target, landing, failed_motor }
    }

    /// The status to report at `now`.
    pub fn status(&self, now: Time) -> VehicleStatus {
        VehicleStatus {
            time: now,
            armed: self.armed,
            mode: self.mode,
            landed: self.landing.state(),
            failsafe: self.faults.monitor.worst(),
            mission: self.mission.progress(),
            last_refusal: self.announcements.last().map(str::to_owned),
            refusals: self.announcements.count(),
            armable: !self.armed && self.vehicle_ready(now).is_ok(),
            home: self.home.status(),
            geofence_enabled: self.geofence.enabled(),
            failed_motor: self.failed_motor_u8(),
            speed_cap: self.avoidance.speed_cap,
            vertical_limit: self.vertical.status(),
            fence: self.geofence.status(),
        }
    }

    fn failed_motor_u8(&self) -> Option<u8> {
        // At most `MAX_MOTORS` (8) motors: the index fits.
        self.faults.motors.failed().and_then(|m| u8::try_from(m).ok())
    }
}

/// Modes whose setpoint comes from the sticks: losing them is a failsafe there.
pub(crate) fn flown_from_sticks(mode: FlightMode) -> bool {
    matches!(mode, FlightMode::Stabilize | FlightMode::Acro | FlightMode::AltHold | FlightMode::PosHold)
}

/// Whether `target` asks the vehicle at `nav` to go down: a downward velocity, or a height
/// target at least [`DESCENT_DEMAND_M`] below it.
fn descends(target: &SetpointTarget, nav: &NavState) -> bool {
    let SetpointTarget::Trajectory(t) = target else { return false };
    let down_velocity = t.velocity_ned_m_s[2].is_some_and(|v| v > DESCENT_DEMAND_M_S);
    let down_position = t.position_ned_m[2].is_some_and(|d| d - nav.position_ned_m[2] > DESCENT_DEMAND_M);
    down_velocity || down_position
}

/// The attitude of a state `on_nav` kept, which is a rotation (identity is never reached).
pub(crate) fn attitude(nav: &NavState) -> UnitQuaternion<f64> {
    unit_quaternion(nav.attitude).unwrap_or_else(|_| UnitQuaternion::identity())
}

fn heading(nav: &NavState) -> f64 {
    yaw_of(&attitude(nav))
}

#[cfg(test)]
pub(crate) mod tests;
