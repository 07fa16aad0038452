//! The commander: arming, flight modes, missions and failsafes — a pure state machine fed
//! with messages and asked, at its own pace, for the setpoint to fly and the status to report.
//!
//! Home is the NED position where the vehicle armed, unless a ground station set it
//! (MAV_CMD_DO_SET_HOME, see `home`): then it stays where it was put. Failsafes follow PX4's precedence
//! (warn < hold < RTL < land < disarm): the active cause with the strongest action decides,
//! its cause is reported in `VehicleStatus`, and while an RTL-or-stronger failsafe is active
//! the pilot may only switch to LAND (PX4 lets the pilot take over in some cases; we are
//! conservative here). On the ground, a failsafe of RTL or stronger disarms.

mod arming;
mod avoidance;
mod failsafe;
mod failsafe_actions;
mod feasibility;
mod home;
mod land_detector;
mod live_params;
mod mission_current;
mod mission_runner;
mod modes;
mod motor_check;
mod params;
mod pilot_input;
mod shutdown;
mod vertical;

use kestrel_proto::Time;
use kestrel_proto::attitude::{tilt_rad, unit_quaternion};
use kestrel_proto::geo::LocalFrame;
use kestrel_proto::messages::{
    ActuatorOutputs, AvoidanceCommand, BatteryStatus, CalibrationStatus, Command, EscTelemetry,
    FailsafeAction, FailsafeCause, FlightMode, Home, LandedState, ManualControl, Mission, MissionProgress,
    NavState, ParamDecl, RangefinderSample, Setpoint, SetpointTarget, SupervisorEvent, SupervisorEventKind,
    VehicleCommand, VehicleStatus, VerticalLimitKind, VerticalLimitStatus,
};
use nalgebra::{UnitQuaternion, Vector3};

pub use arming::{Refusal, needs_position, needs_sticks};
pub use avoidance::{cap_braking, frd_to_ned};
pub use failsafe::{FailsafeMonitor, FailsafeRecord, HeldFor, NetHeldFor};
pub use kestrel_proto::param_def::{ParamChange, ParamRefused};
pub use land_detector::LandDetector;
pub use mission_runner::{MissionRunner, MissionStep};
pub use motor_check::{COMMAND_STALE_S, MotorCheck};
pub use params::{CommanderParams, FailsafeParams, FeasibilityParams, GeofenceParams};
pub use pilot_input::{PilotInput, PilotLimits, SticksHeard};
pub use vertical::VerticalParams;

use crate::error::InvalidParam;
use crate::flip::Flip;
use crate::position::yaw_of;
use arming::{LOW_THROTTLE, refuse};
use modes::{Hold, RtlPhase};

/// A vehicle within this of the ceiling the upward rangefinder sets (m) is held by it.
const AT_CEILING_M: f64 = 0.5;
/// Height above home at which the vehicle counts as airborne (m).
const AIRBORNE_HEIGHT_M: f64 = 0.5;
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
    /// Armed and on the ground since then without a take-off (`disarm_delay_s`).
    idle_on_ground_since: Option<Time>,
    landed: LandedState,
    /// The state flown on: the estimator's, or the backup attitude's while the estimator's is
    /// stale (`on_backup_nav`).
    nav: Option<NavState>,
    /// Time of the estimator's newest state: its staleness is a failsafe whatever the backup
    /// does.
    estimator_nav_at: Option<Time>,
    /// The estimator's newest state had a valid attitude.
    estimator_attitude_valid: bool,
    /// `nav` is the backup attitude's.
    on_backup: bool,
    frame: Option<LocalFrame>,
    /// Polygon fence vertices, north/east (m), once the NED origin is known.
    fence_ned: Vec<[f64; 2]>,
    home_ned: Option<Vector3<f64>>,
    /// Home was set by a ground station: arming no longer moves it (ArduPilot's locked home).
    home_locked: bool,
    /// Moves of home so far (`Home::revision`).
    home_revision: u32,
    /// A geofence breach triggers its failsafe (MAV_CMD_DO_FENCE_ENABLE switches it).
    geofence_enabled: bool,
    battery: Option<BatteryStatus>,
    /// The calibration's last word: required steps missing, one running (pre-arm).
    calibration: Option<CalibrationStatus>,
    /// The receiver's and the ground station's sticks and the ground station's link: who is in
    /// control (`pilot_input`).
    pilot: PilotInput,
    mission: Option<Mission>,
    runner: Option<MissionRunner>,
    /// The item a ground station made current while no mission was being flown: the next run
    /// of the mission starts there (cleared once it does, or by a new mission).
    mission_start: Option<usize>,
    last_progress: MissionProgress,
    hold: Hold,
    rtl: RtlPhase,
    flip: Option<Flip>,
    guided: modes::GuidedTarget,
    /// Where the nose points in GUIDED and AUTO (CONDITION_YAW, DO_SET_ROI_LOCATION); cleared
    /// by a mode change and DO_SET_ROI_NONE.
    yaw_target: Option<modes::YawTarget>,
    /// AUTO is paused (DO_PAUSE_CONTINUE): hold where the vehicle stopped, the mission's place kept.
    paused: bool,
    /// When the GUIDED target last came: a velocity stream that stops is held (`guided_timeout_s`).
    guided_at: Option<Time>,
    takeoff_height_m: f64,
    land_detector: LandDetector,
    /// The land detector outside the landing modes: still for a while although the setpoint
    /// asks to go down means the ground holds the vehicle (a waypoint below the ground, a pilot
    /// who landed in POSHOLD). PX4's and ArduPilot's detectors do not depend on the mode either.
    ground_contact: LandDetector,
    /// The last setpoint asked for a descent the vehicle should be making.
    descent_demanded: bool,
    failsafes: FailsafeMonitor,
    applied_action: Option<FailsafeAction>,
    critical_failure: bool,
    /// ESC telemetry against the motor commands: a motor that stopped.
    motors: MotorCheck,
    /// The pack voltage under `battery_low_volt` / `battery_critical_volt`, and since when.
    low_volt: HeldFor,
    critical_volt: HeldFor,
    /// How long the NavState has been stale (older than `nav_timeout_s`), net of its returns
    /// (`failsafe.nav_stale_s`).
    nav_stale: NetHeldFor,
    last_refusal: Option<String>,
    /// Refusals so far (`VehicleStatus::refusals`).
    refusals: u32,
    last_update: Option<Time>,
    avoidance: avoidance::AvoidanceLoop,
    /// The up- and downward rangefinders (`vertical`).
    rangefinders: vertical::Rangefinders,
    /// A landing moving off an obstacle's top; reset by a mode change.
    landing_search: vertical::LandingSearch,
    /// What the rangefinders hold back this update, for the status.
    vertical_limit: Option<VerticalLimitStatus>,
    /// A mode lowered its climb's goal to the ceiling this update.
    ceiling_held: bool,
}

impl Commander {
    pub fn new(params: CommanderParams) -> Result<Commander, InvalidParam> {
        params.validate()?;
        let motors = MotorCheck::new(params.failsafe.motor_failure)
            .map_err(|e| InvalidParam::new("failsafe.motor_failure", e.to_string()))?;
        Ok(Commander {
            motors,
            takeoff_height_m: params.takeoff_altitude_m,
            params,
            armed: false,
            mode: FlightMode::Guided,
            boot_mode: true,
            idle_on_ground_since: None,
            landed: LandedState::OnGround,
            nav: None,
            estimator_nav_at: None,
            estimator_attitude_valid: false,
            on_backup: false,
            frame: None,
            fence_ned: Vec::new(),
            home_ned: None,
            home_locked: false,
            home_revision: 0,
            geofence_enabled: true,
            battery: None,
            calibration: None,
            pilot: PilotInput::default(),
            mission: None,
            runner: None,
            mission_start: None,
            last_progress: MissionProgress::default(),
            hold: Hold::default(),
            rtl: RtlPhase::Climb,
            flip: None,
            guided: modes::GuidedTarget::Hold,
            guided_at: None,
            paused: false,
            yaw_target: None,
            land_detector: LandDetector::default(),
            ground_contact: LandDetector::default(),
            descent_demanded: false,
            failsafes: FailsafeMonitor::default(),
            applied_action: None,
            critical_failure: false,
            low_volt: HeldFor::default(),
            critical_volt: HeldFor::default(),
            nav_stale: NetHeldFor::default(),
            last_refusal: None,
            refusals: 0,
            last_update: None,
            avoidance: avoidance::AvoidanceLoop::default(),
            rangefinders: vertical::Rangefinders::default(),
            landing_search: vertical::LandingSearch::default(),
            vertical_limit: None,
            ceiling_held: false,
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
        // `apply` validated the whole set, the detector's part with it.
        self.motors
            .set_params(self.params.failsafe.motor_failure)
            .map_err(|e| ParamRefused::Invalid { name: name.to_owned(), reason: e.to_string() })?;
        Ok(change)
    }

    /// The commander's live parameters with their current values, for the link (`param_decl`;
    /// `start` when the actor has just started).
    pub fn param_decl(&self, owner: &str, start: bool, now: Time) -> ParamDecl {
        kestrel_proto::param_def::declare(live_params::LIVE_PARAMS, &self.params, owner, start, now)
    }

    pub fn armed(&self) -> bool {
        self.armed
    }

    pub fn mode(&self) -> FlightMode {
        self.mode
    }

    pub fn landed(&self) -> LandedState {
        self.landed
    }

    /// Home, NED from the estimator's origin (m); set at arming or by a ground station.
    pub fn home_ned(&self) -> Option<Vector3<f64>> {
        self.home_ned
    }

    /// Every failsafe that fired while armed.
    pub fn failsafe_log(&self) -> &[FailsafeRecord] {
        self.failsafes.log()
    }

    /// A new navigation state (non-finite ones, and attitudes that are no rotation, are
    /// ignored: the loop rejects them too).
    pub fn on_nav(&mut self, nav: &NavState) {
        if !usable(nav) {
            return;
        }
        self.estimator_nav_at = Some(nav.time);
        self.estimator_attitude_valid = nav.valid.attitude;
        if !nav.valid.attitude && self.on_backup {
            // A restarted estimator still aligning: the backup flies on.
            return;
        }
        if self.on_backup {
            tracing::warn!(at = %nav.time, "estimator back: flying on its state again");
            self.on_backup = false;
        }
        self.take_nav(nav);
    }

    /// A state of the controller's backup attitude, published while the loop flies on it: taken
    /// in place of the estimator's while that is stale, so the modes, the landing and the land
    /// detector have an attitude, a height and a climb rate (no horizontal position). The
    /// switch is announced. The estimator's staleness stays a failsafe (`check_failsafes`).
    pub fn on_backup_nav(&mut self, nav: &NavState) {
        if !usable(nav) || (self.estimator_fresh(nav.time) && self.estimator_attitude_valid) {
            return;
        }
        if !self.on_backup {
            tracing::error!(at = %nav.time, "estimator failed: flying on the backup attitude");
            self.announce("EKF failed: backup attitude".to_owned());
            self.on_backup = true;
        }
        self.take_nav(nav);
    }

    /// The state flown on is the backup attitude's.
    pub fn on_backup_attitude(&self) -> bool {
        self.on_backup
    }

    /// The estimator's newest state is no older than `nav_timeout_s` at `now`.
    fn estimator_fresh(&self, now: Time) -> bool {
        self.estimator_nav_at
            .is_some_and(|t| now.saturating_since(t).as_secs_f64() <= self.params.nav_timeout_s)
    }

    fn take_nav(&mut self, nav: &NavState) {
        if self.frame.is_none()
            && let Some(origin) = nav.origin
        {
            let frame = LocalFrame::new(origin);
            self.fence_ned = self
                .params
                .geofence
                .polygon
                .iter()
                .map(|&[lat_deg, lon_deg]| {
                    let ned =
                        frame.to_ned(kestrel_proto::geo::Geodetic { lat_deg, lon_deg, alt_m: origin.alt_m });
                    [ned[0], ned[1]]
                })
                .collect();
            self.frame = Some(frame);
        }
        self.nav = Some(nav.clone());
    }

    /// The motor commands the loop published, for the motor check.
    pub fn on_actuators(&mut self, outputs: &ActuatorOutputs) {
        self.motors.on_actuators(outputs);
    }

    /// What the ESCs say the motors produce: a motor declared failed is announced (STATUSTEXT),
    /// shown in the status, left out of the allocation, and a failsafe where the others cannot
    /// hold every axis.
    pub fn on_esc_telemetry(&mut self, esc: &EscTelemetry) {
        if !self.armed {
            return;
        }
        if let Some(motor) = self.motors.on_telemetry(esc) {
            let continues = self.motors.others_hold_all_axes();
            tracing::warn!(motor = motor + 1, at = %esc.time, continues, "motor failure detected");
            let what = if continues { "flying on the others" } else { "cannot hold yaw" };
            self.announce(format!("Motor {} failure: {what}", motor + 1));
        }
    }

    /// The motor declared failed this flight (0-based), if any.
    pub fn failed_motor(&self) -> Option<usize> {
        self.motors.failed()
    }

    pub fn on_battery(&mut self, battery: &BatteryStatus) {
        self.battery = Some(battery.clone());
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
        if let Err(why) = self.rangefinders.on_sample(sample) {
            tracing::warn!(orientation = ?sample.orientation, %why, "rangefinder sample refused");
        }
    }

    /// The highest the vehicle may climb to now (NED down, m), if something is overhead.
    fn ceiling_down_m(&self, now: Time, nav: &NavState) -> Option<f64> {
        self.rangefinders.ceiling_down_m(now, nav, &self.params.vertical)
    }

    /// Holding because the avoidance stream is stale.
    pub fn avoidance_holding(&self) -> bool {
        self.avoidance.active() && self.avoidance.state.is_some() && self.avoidance.holding
    }

    /// A failure report from the supervisor; a flight-critical actor's failure is a failsafe.
    pub fn on_supervisor(&mut self, event: &SupervisorEvent) {
        if event.critical && matches!(event.kind, SupervisorEventKind::Failed | SupervisorEventKind::GaveUp) {
            tracing::error!(actor = %event.actor, reason = %event.reason, "flight-critical actor failed");
            self.critical_failure = true;
        }
    }

    /// A new mission; replaces the old one, and one of no items clears it. Refused when a field
    /// is not a number or there are too many items (`Mission::check_fields`, which the link runs
    /// before it acknowledges an upload). One that is well-formed but cannot be flown from here
    /// (below home, outside the fence, too far: `feasibility`) is kept — the ground station holds
    /// it, and flying an older one instead would be worse — and refused, by item, when AUTO is
    /// asked for; the reason is reported at once as well.
    ///
    /// While AUTO flies the old one, the new one is flown from the same item index (its last
    /// item when it is shorter: `MissionRunner::replace`), as ArduCopter restarts its current
    /// command; one that cannot be flown from here pauses the mission where the vehicle is (as
    /// DO_PAUSE_CONTINUE does), the reason said, until a ground station continues it or sends
    /// another. Held by `tests::a_mission_uploaded_in_auto_is_flown_from_the_same_item`.
    pub fn on_mission(&mut self, mission: Mission) -> Result<(), Refusal> {
        let flying = self.armed && self.mode == FlightMode::Auto && self.runner.is_some();
        if mission.items.is_empty() {
            // No items: the ground station cleared its mission (MISSION_CLEAR_ALL, or home
            // alone uploaded). Not while it is flown: the link refuses that clear as well.
            if flying {
                return self.refused(refuse("mission clear refused while flying AUTO"));
            }
            self.mission = None;
            self.runner = None;
            self.mission_start = None;
            self.last_progress = MissionProgress::default();
            return Ok(());
        }
        let fields = feasibility::check_fields(&mission);
        self.refused(fields)?;
        let feasible = self.mission_feasible(&mission);
        let infeasible = self.refused(feasible).is_err();
        self.mission = Some(mission.clone());
        self.mission_start = None;
        if flying && let Some(runner) = &mut self.runner {
            runner.replace(mission);
            tracing::info!(index = runner.progress().current, "mission replaced in flight");
            // Drop what AUTO latched for the old item (a landing under way, a held position).
            let paused = self.paused || infeasible;
            self.enter(FlightMode::Auto);
            self.paused = paused;
        } else {
            self.last_progress = MissionRunner::new(mission).progress();
            self.runner = None;
        }
        Ok(())
    }

    /// A command; refused ones say why (also in the next status).
    pub fn on_command(&mut self, cmd: &VehicleCommand) -> Result<(), Refusal> {
        let now = cmd.time;
        let result = match cmd.command {
            Command::Heartbeat { system_id } => {
                // Another system's heartbeat is answered by the link and holds off nothing here.
                self.pilot.on_heartbeat(system_id, now, &PilotLimits::of(&self.params));
                Ok(())
            }
            Command::Arm => self.arm(now),
            Command::Disarm { force } => {
                if self.landed == LandedState::OnGround || force {
                    self.disarm("commanded");
                    Ok(())
                } else {
                    refuse("disarm refused in flight (use force)")
                }
            }
            Command::SetMode(mode) => self.set_mode(now, mode),
            Command::Takeoff { altitude_m } => {
                if !(altitude_m.is_finite()
                    && altitude_m > 1.0
                    && altitude_m <= self.params.geofence.max_altitude_m)
                {
                    refuse(format!("take-off altitude {altitude_m} m out of range"))
                } else if !self.armed {
                    refuse("take-off refused: not armed")
                } else {
                    self.takeoff_height_m = altitude_m;
                    self.set_mode(now, FlightMode::Takeoff)
                }
            }
            Command::Land => self.set_mode(now, FlightMode::Land),
            Command::Shutdown => {
                self.on_shutdown(now);
                Ok(())
            }
            Command::ReturnToLaunch => self.set_mode(now, FlightMode::ReturnToLaunch),
            Command::MissionStart => self.mode_allowed(now, FlightMode::Auto).and_then(|()| {
                // MISSION_START in AUTO restarts the mission from its first item (or the one a
                // ground station made current since): a fresh run replaces the one flying.
                let restart = self.mode == FlightMode::Auto;
                if restart {
                    self.runner = None;
                }
                let r = self.set_mode(now, FlightMode::Auto);
                if restart {
                    self.enter(FlightMode::Auto);
                }
                r
            }),
            Command::Flip => self.start_flip(now),
            Command::GotoNed { position_ned_m } => {
                self.guided_command(now, modes::GuidedTarget::Position(position_ned_m))
            }
            Command::VelocityNed { velocity_ned_m_s } => {
                self.guided_command(now, modes::GuidedTarget::Velocity(velocity_ned_m_s))
            }
            Command::SetHome { point } => self.set_home(now, point),
            Command::SetGeofence { enabled } => {
                // Accepted in flight, as ArduPilot does: switching it off clears a breach's
                // failsafe cause but not the RTL it started; switching it on while outside
                // breaches at once.
                if enabled != self.geofence_enabled {
                    tracing::info!(enabled, "geofence");
                }
                self.geofence_enabled = enabled;
                Ok(())
            }
            Command::SetMissionCurrent { index } => self.set_mission_current(index),
            Command::ChangeSpeed { speed_m_s } => self.change_speed(speed_m_s),
            Command::Yaw { .. } | Command::RegionOfInterest { .. }
                if !matches!(self.mode, FlightMode::Guided | FlightMode::Auto) =>
            {
                refuse("yaw and region of interest are flown in GUIDED and AUTO only")
            }
            Command::Yaw { heading_deg, relative_deg } => {
                let current = self.nav.as_ref().map_or(0.0, heading);
                let yaw = match (heading_deg, relative_deg) {
                    (Some(h), None) if h.is_finite() => Some(h.to_radians()),
                    (None, Some(r)) if r.is_finite() => Some(current + r.to_radians()),
                    _ => None,
                };
                match yaw {
                    Some(yaw) => {
                        self.yaw_target = Some(modes::YawTarget::Heading(yaw));
                        Ok(())
                    }
                    None => refuse("yaw refused: give one finite heading or turn"),
                }
            }
            Command::RegionOfInterest { position_ned_m: Some(p) } if p.iter().all(|v| v.is_finite()) => {
                self.yaw_target = Some(modes::YawTarget::Towards(p));
                Ok(())
            }
            Command::RegionOfInterest { position_ned_m: Some(_) } => {
                refuse("region of interest is not finite")
            }
            Command::RegionOfInterest { position_ned_m: None } => {
                self.yaw_target = None;
                Ok(())
            }
            Command::PauseMission | Command::ContinueMission
                if self.mode != FlightMode::Auto || self.runner.is_none() =>
            {
                refuse("pause/continue refused: no mission is being flown in AUTO")
            }
            Command::PauseMission => {
                if !self.paused {
                    tracing::info!("mission paused");
                    self.hold = modes::Hold::default();
                }
                self.paused = true;
                Ok(())
            }
            Command::ContinueMission => {
                if self.paused {
                    tracing::info!("mission continued");
                }
                self.paused = false;
                Ok(())
            }
        };
        self.refused(result)
    }

    /// Records `text` as the newest refusal (or notice) for the status and its STATUSTEXT.
    pub(crate) fn announce(&mut self, text: String) {
        self.refusals = self.refusals.wrapping_add(1);
        self.last_refusal = Some(text);
    }

    fn refused<T>(&mut self, result: Result<T, Refusal>) -> Result<T, Refusal> {
        if let Err(r) = &result {
            tracing::info!(reason = %r, "refused");
            self.announce(r.0.clone());
        }
        result
    }

    fn arm(&mut self, now: Time) -> Result<(), Refusal> {
        if self.armed {
            // Already armed is done, as in ArduPilot and PX4: a ground station whose ACK was lost
            // retries, and must hear ACCEPTED, not a refusal of what it asked for.
            return Ok(());
        }
        self.prearm(now)?;
        let nav = self.fresh_nav(now).cloned();
        self.armed = true;
        if !self.home_locked {
            self.home_ned = nav.map(|n| Vector3::from(n.position_ned_m));
            self.home_revision += 1;
        }
        self.landed = LandedState::OnGround;
        self.failsafes.clear();
        self.applied_action = None;
        self.critical_failure = false;
        self.motors.reset();
        self.enter(self.mode);
        if self.mode == FlightMode::Auto {
            self.runner = self.new_runner();
        }
        tracing::info!(mode = ?self.mode, "armed");
        Ok(())
    }

    fn disarm(&mut self, why: &str) {
        if self.armed {
            tracing::info!(why, "disarmed");
        }
        self.armed = false;
        self.idle_on_ground_since = None;
        self.flip = None;
        self.landed = LandedState::OnGround;
        self.landing_search = vertical::LandingSearch::default();
        // As PX4: failsafes belong to a flight. Latched causes (battery, estimator, critical
        // actor) would otherwise refuse every later arming; the pre-arm checks judge afresh.
        self.failsafes.clear();
    }

    fn set_mode(&mut self, now: Time, mode: FlightMode) -> Result<(), Refusal> {
        self.mode_allowed(now, mode)?;
        self.boot_mode = false;
        if mode == FlightMode::Auto && (self.runner.is_none() || self.mode != FlightMode::Auto) {
            self.runner = self.new_runner();
        }
        // The mode already active is accepted without re-entering it: RTL must not climb again
        // from its landing phase, nor LAND restart the land detector.
        if mode != self.mode {
            self.enter(mode);
        }
        Ok(())
    }

    /// Switches mode and resets what the new mode latches.
    fn enter(&mut self, mode: FlightMode) {
        if mode != self.mode {
            tracing::info!(from = ?self.mode, to = ?mode, "mode");
        }
        self.mode = mode;
        self.hold = Hold::default();
        self.rtl = RtlPhase::Climb;
        self.flip = None;
        self.guided = modes::GuidedTarget::Hold;
        self.paused = false;
        self.yaw_target = None;
        self.land_detector.reset();
        self.avoidance.reset();
        self.landing_search = vertical::LandingSearch::default();
    }

    fn start_flip(&mut self, now: Time) -> Result<(), Refusal> {
        if self.mode != FlightMode::Acro {
            return refuse("flip refused: only in ACRO");
        }
        if self.landed != LandedState::InAir {
            return refuse("flip refused: not flying");
        }
        let Some(nav) = self.fresh_nav(now).cloned() else {
            return refuse("flip refused: no navigation state");
        };
        if self.height_m(&nav) < self.params.flip_min_height_m {
            return refuse(format!("flip refused: below {} m", self.params.flip_min_height_m));
        }
        self.flip = Some(Flip::start(&nav, self.params.hover_thrust));
        Ok(())
    }

    /// DO_CHANGE_SPEED: the running mission's leg speed (m/s), within the feasibility limit.
    fn change_speed(&mut self, speed_m_s: f64) -> Result<(), Refusal> {
        let max = self.params.feasibility.max_velocity_m_s;
        if !(speed_m_s.is_finite() && speed_m_s > 0.0 && speed_m_s <= max) {
            return refuse(format!("speed {speed_m_s} m/s refused: 0 < speed <= {max} m/s"));
        }
        match (&mut self.runner, self.mode) {
            (Some(runner), FlightMode::Auto) => {
                runner.set_cruise(speed_m_s);
                Ok(())
            }
            _ => refuse("DO_CHANGE_SPEED refused: flown in AUTO only"),
        }
    }

    fn guided_command(&mut self, now: Time, target: modes::GuidedTarget) -> Result<(), Refusal> {
        if self.mode != FlightMode::Guided {
            return refuse("position/velocity targets are accepted in GUIDED only");
        }
        let finite = match target {
            modes::GuidedTarget::Position(v) | modes::GuidedTarget::Velocity(v) => {
                v.iter().all(|x| x.is_finite())
            }
            modes::GuidedTarget::Hold => true,
        };
        if !finite {
            return refuse("guided target is not finite");
        }
        match target {
            modes::GuidedTarget::Position(p) => {
                if let Some(why) = self.guided_position_refused(&Vector3::from(p)) {
                    return refuse(format!("guided target refused: {why}"));
                }
            }
            modes::GuidedTarget::Velocity(v) => {
                let (speed, max) = (Vector3::from(v).norm(), self.params.feasibility.max_velocity_m_s);
                if speed > max {
                    return refuse(format!("guided velocity refused: {speed:.1} m/s, at most {max:.1} m/s"));
                }
            }
            modes::GuidedTarget::Hold => {}
        }
        self.guided = target;
        self.guided_at = Some(now);
        Ok(())
    }

    /// The pilot's sticks if they are fresh at `now` (`pilot_input`: the receiver's while it is
    /// healthy, else the ground station's): a MANUAL_CONTROL sent once, seconds ago, must not
    /// fly the vehicle.
    pub(crate) fn sticks(&self, now: Time) -> Option<&ManualControl> {
        self.pilot.sticks(now, &PilotLimits::of(&self.params))
    }

    /// The newest NavState if it is fresh at `now`.
    fn fresh_nav(&self, now: Time) -> Option<&NavState> {
        self.nav.as_ref().filter(|n| now.saturating_since(n.time).as_secs_f64() <= self.params.nav_timeout_s)
    }

    fn tilt_rad(&self, nav: &NavState) -> f64 {
        tilt_rad(&attitude(nav))
    }

    fn home_or(&self, nav: &NavState) -> Vector3<f64> {
        self.home_ned.unwrap_or_else(|| Vector3::from(nav.position_ned_m))
    }

    /// Height above home (m).
    fn height_m(&self, nav: &NavState) -> f64 {
        self.home_or(nav).z - nav.position_ned_m[2]
    }

    fn outside_geofence(&self, nav: &NavState, home: &Vector3<f64>) -> bool {
        if !(nav.valid.horizontal_position && nav.valid.vertical_position) {
            return false;
        }
        let p = Vector3::from(nav.position_ned_m);
        let g = &self.params.geofence;
        let radius = (p.x - home.x).hypot(p.y - home.y);
        let height = home.z - p.z;
        radius > g.max_radius_m || height > g.max_altitude_m || !inside_polygon(&self.fence_ned, p.x, p.y)
    }

    /// Runs the state machine at `now` and returns the setpoint to fly.
    pub fn update(&mut self, now: Time) -> Setpoint {
        let dt_s = self.last_update.map_or(0.0, |t| now.saturating_since(t).as_secs_f64().min(0.1));
        self.last_update = Some(now);
        self.track_landed(now);
        self.disarm_if_idle(now);
        self.check_failsafes(now);
        self.ceiling_held = false;
        let mut target = if self.armed { self.fly(now, dt_s) } else { SetpointTarget::MotorsOff };
        self.hold_below_ceiling(now, &mut target);
        self.descent_demanded = self.nav.as_ref().is_some_and(|n| descends(&target, n));
        if self.armed && self.mode == FlightMode::Auto && self.runner.is_some() {
            // The run has started from the item a ground station chose; later runs start over.
            self.mission_start = None;
        }
        let landing = self.armed && self.landed == LandedState::Landing;
        let failed_motor = self.failed_motor_u8();
        Setpoint { time: now, armed: self.armed, target, landing, failed_motor }
    }

    /// The status to report at `now`.
    pub fn status(&self, now: Time) -> VehicleStatus {
        VehicleStatus {
            time: now,
            armed: self.armed,
            mode: self.mode,
            landed: self.landed,
            failsafe: self.failsafes.worst(),
            mission: self.runner.as_ref().map_or(self.last_progress, MissionRunner::progress),
            last_refusal: self.last_refusal.clone(),
            refusals: self.refusals,
            armable: !self.armed && self.vehicle_ready(now).is_ok(),
            home: self
                .home_ned
                .map(|h| Home { position_ned_m: [h.x, h.y, h.z], revision: self.home_revision }),
            geofence_enabled: self.geofence_enabled,
            failed_motor: self.failed_motor_u8(),
            speed_cap: self.avoidance.speed_cap,
            vertical_limit: self.vertical_limit,
        }
    }

    /// Keeps `target` below what the upward rangefinder sees (`vertical`), and notes in the
    /// status what holds the vehicle back vertically this update.
    fn hold_below_ceiling(&mut self, now: Time, target: &mut SetpointTarget) {
        // Held by the ceiling last update: a wider band keeps the status from flickering.
        let band_m = match self.vertical_limit {
            Some(VerticalLimitStatus { kind: VerticalLimitKind::Overhead, .. }) => 2.0 * AT_CEILING_M,
            _ => AT_CEILING_M,
        };
        self.vertical_limit = self
            .landing_search
            .below_m
            .filter(|_| self.landing_search.searching())
            .map(|distance_m| VerticalLimitStatus { kind: VerticalLimitKind::ObstacleBelow, distance_m });
        let Some(nav) = &self.nav else { return };
        let Some(ceiling) = self.ceiling_down_m(now, nav) else { return };
        let down = nav.position_ned_m[2];
        // Held: the setpoint was lowered, a mode lowered its goal (or kept the vehicle on the
        // ground), or the vehicle sits at the ceiling not asked to descend (a hold there would
        // otherwise flicker in and out of the status).
        let held = match target {
            SetpointTarget::Trajectory(sp) => {
                let at_ceiling = down - ceiling < band_m && sp.velocity_ned_m_s[2].is_none_or(|v| v <= 0.0);
                vertical::hold_below(sp, down, ceiling, &self.params.vertical) || at_ceiling
            }
            _ => false,
        };
        if held || self.ceiling_held {
            let distance_m = down - ceiling + self.params.vertical.margin_m;
            self.vertical_limit = Some(VerticalLimitStatus { kind: VerticalLimitKind::Overhead, distance_m });
        }
    }

    fn failed_motor_u8(&self) -> Option<u8> {
        // At most `MAX_MOTORS` (8) motors: the index fits.
        self.motors.failed().and_then(|m| u8::try_from(m).ok())
    }

    fn check_failsafes(&mut self, now: Time) {
        let fs = self.params.failsafe.clone();
        let armed = self.armed;
        let nav = self.nav.clone();
        // The estimator's own freshness: the backup attitude lands the vehicle, it does not
        // stand in for the estimator's health.
        let fresh = self.estimator_fresh(now);
        let limits = PilotLimits::of(&self.params);
        // Each loss on its own source's silence (`pilot_input`): the receiver never holds off
        // the ground station's, nor MAVLink sticks the receiver's.
        let link_lost = self.pilot.gcs_lost(now, &limits);
        let remaining = self.battery.as_ref().map(|b| b.remaining);
        let volts = self.battery.as_ref().map(|b| b.voltage_v);
        let under = |threshold: f64| threshold > 0.0 && volts.is_some_and(|v| v < threshold);
        let timer = fs.battery_volt_timer_s;
        let low_volt = self.low_volt.check(now, armed && under(fs.battery_low_volt), timer);
        let critical_volt = self.critical_volt.check(now, armed && under(fs.battery_critical_volt), timer);
        if !armed {
            self.nav_stale.reset();
        }
        let nav_stale = self.nav_stale.check(now, armed && !fresh, fs.nav_stale_s);
        let unhealthy = nav.as_ref().is_some_and(|n| {
            fresh && (!n.valid.attitude || (needs_position(self.mode) && !n.valid.horizontal_position))
        });
        let avoidance_lost = self.avoidance.silent_for_s(now).is_some_and(|s| s > fs.avoidance_lost_s);
        let sticks_lost = flown_from_sticks(self.mode) && self.pilot.sticks_lost(now, &limits);
        let fence = self.geofence_enabled
            && nav.as_ref().is_some_and(|n| {
                let home = self.home_or(n);
                self.outside_geofence(n, &home)
            });
        let m = &mut self.failsafes;
        m.set(now, FailsafeCause::DataLinkLost, armed && link_lost, fs.link_action);
        m.set(
            now,
            FailsafeCause::BatteryLow,
            armed && (remaining.is_some_and(|r| r < fs.battery_low) || low_volt),
            fs.battery_low_action,
        );
        m.set(
            now,
            FailsafeCause::BatteryCritical,
            armed && (remaining.is_some_and(|r| r < fs.battery_critical) || critical_volt),
            fs.battery_critical_action,
        );
        m.set(now, FailsafeCause::GeofenceBreach, armed && fence, fs.geofence_action);
        m.set(now, FailsafeCause::EstimatorUnhealthy, armed && unhealthy, fs.estimator_action);
        m.set(now, FailsafeCause::NavStateStale, nav_stale, FailsafeAction::Land);
        m.set(
            now,
            FailsafeCause::CriticalActorFailed,
            armed && self.critical_failure,
            fs.critical_actor_action,
        );
        m.set(now, FailsafeCause::ManualControlLost, armed && sticks_lost, fs.manual_action);
        m.set(now, FailsafeCause::AvoidanceLost, armed && avoidance_lost, fs.avoidance_action);
        let motor_failed = self.motors.failed().is_some() && !self.motors.others_hold_all_axes();
        m.set(now, FailsafeCause::MotorFailure, armed && motor_failed, fs.motor_failure_action);
        self.apply_failsafe(now);
    }

    fn apply_failsafe(&mut self, now: Time) {
        let Some(worst) = self.failsafes.worst() else {
            self.applied_action = None;
            return;
        };
        if !self.armed || self.applied_action.is_some_and(|a| a >= worst.action) {
            return;
        }
        self.applied_action = Some(worst.action);
        let on_ground = self.landed == LandedState::OnGround;
        let position_ok = self.mode_allowed_ignoring_failsafe(now, FlightMode::ReturnToLaunch);
        match worst.action {
            FailsafeAction::Warn => {}
            FailsafeAction::Disarm => self.disarm("failsafe"),
            FailsafeAction::ReturnToLaunch | FailsafeAction::Land if on_ground => {
                self.disarm("failsafe on the ground")
            }
            FailsafeAction::Hold => {
                let mode = if position_ok { FlightMode::PosHold } else { FlightMode::AltHold };
                self.enter(mode);
            }
            FailsafeAction::ReturnToLaunch if position_ok && self.home_ned.is_some() => {
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

    fn mode_allowed_ignoring_failsafe(&self, now: Time, mode: FlightMode) -> bool {
        let nav = self.fresh_nav(now);
        !needs_position(mode)
            || nav.is_some_and(|n| {
                n.valid.horizontal_position && n.valid.vertical_position && n.origin.is_some()
            })
    }

    fn track_landed(&mut self, now: Time) {
        let Some(nav) = self.nav.clone() else { return };
        if !self.armed {
            self.landed = LandedState::OnGround;
            return;
        }
        let landing_mode = self.is_landing();
        let fresh = self.fresh_nav(now).cloned();
        match self.landed {
            LandedState::OnGround if self.height_m(&nav) > AIRBORNE_HEIGHT_M => {
                self.landed = LandedState::InAir
            }
            LandedState::InAir if landing_mode => {
                self.landed = LandedState::Landing;
                self.land_detector.reset();
            }
            LandedState::Landing if !landing_mode => self.landed = LandedState::InAir,
            LandedState::InAir if !landing_mode => {
                let touching = self.descent_demanded
                    && fresh.as_ref().is_some_and(|n| {
                        let (valid, down) = (n.valid.ground_speed_observed(), n.position_ned_m[2]);
                        self.ground_contact.update(
                            now,
                            &n.velocity_ned_m_s,
                            down,
                            valid,
                            self.params.land_detect_s,
                        )
                    });
                if !self.descent_demanded || fresh.is_none() {
                    self.ground_contact.reset();
                }
                if touching {
                    tracing::warn!(mode = ?self.mode, "on the ground outside a landing: disarming");
                    self.announce(format!("{:?}: ground contact, landed", self.mode));
                    self.touched_down();
                }
            }
            // A landing mode entered before the vehicle ever rose past the airborne height (LAND
            // sent at once after a take-off was accepted): it is already down, and the detector
            // must still end the flight, or it would idle armed on the ground for ever.
            LandedState::OnGround | LandedState::Landing if landing_mode && fresh.is_none() => {
                // A frozen NavState's velocity says nothing about the ground: no detection, and
                // the stillness timer starts over once NavStates are fresh again.
                self.land_detector.reset();
            }
            LandedState::OnGround | LandedState::Landing
                if landing_mode
                    && fresh.as_ref().is_some_and(|n| {
                        let (valid, down) = (n.valid.ground_speed_observed(), n.position_ned_m[2]);
                        self.land_detector.update(
                            now,
                            &n.velocity_ned_m_s,
                            down,
                            valid,
                            self.params.land_detect_s,
                        )
                    }) =>
            {
                if let Some(runner) = &mut self.runner
                    && self.mode == FlightMode::Auto
                {
                    runner.landed();
                }
                self.touched_down();
            }
            _ => {}
        }
    }

    /// Armed on the ground for `disarm_delay_s` without taking off: disarm (ArduCopter's
    /// `DISARM_DELAY`). A pilot's throttle above low in a stick mode restarts the wait.
    fn disarm_if_idle(&mut self, now: Time) {
        let throttle_up =
            needs_sticks(self.mode) && self.sticks(now).is_some_and(|m| m.throttle > LOW_THROTTLE);
        let idle = self.armed && self.landed == LandedState::OnGround && !throttle_up;
        if !idle || self.params.disarm_delay_s <= 0.0 {
            self.idle_on_ground_since = None;
            return;
        }
        let since = *self.idle_on_ground_since.get_or_insert(now);
        if now.saturating_since(since).as_secs_f64() >= self.params.disarm_delay_s {
            let why = format!("no take-off within DISARM_DELAY ({} s)", self.params.disarm_delay_s);
            self.announce(format!("disarmed: {why}"));
            self.disarm(&why);
        }
    }

    /// The land detector tripped: on the ground, the mission's progress kept, disarmed.
    fn touched_down(&mut self) {
        self.landed = LandedState::OnGround;
        self.ground_contact.reset();
        if let Some(runner) = &self.runner {
            self.last_progress = runner.progress();
        }
        self.disarm("landed");
    }

    fn is_landing(&self) -> bool {
        let landing = match self.mode {
            FlightMode::Land => true,
            FlightMode::ReturnToLaunch => self.rtl == RtlPhase::Land,
            FlightMode::Auto => self.hold.landing,
            _ => false,
        };
        // Holding above an obstacle's top while moving off it is no descent: the land detector
        // would take the stillness for the ground.
        landing && !self.landing_search.searching()
    }
}

/// A state `on_nav` keeps: finite, and its attitude a rotation (the loop rejects others too).
fn usable(nav: &NavState) -> bool {
    nav.position_ned_m.iter().chain(&nav.velocity_ned_m_s).all(|v| v.is_finite())
        && unit_quaternion(nav.attitude).is_ok()
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

/// Even-odd ray casting; an empty polygon contains everything.
fn inside_polygon(vertices: &[[f64; 2]], north: f64, east: f64) -> bool {
    if vertices.len() < 3 {
        return true;
    }
    let mut inside = false;
    let mut j = vertices.len() - 1;
    for i in 0..vertices.len() {
        let ([ni, ei], [nj, ej]) = (vertices[i], vertices[j]);
        if (ei > east) != (ej > east) && north < (nj - ni) * (east - ei) / (ej - ei) + ni {
            inside = !inside;
        }
        j = i;
    }
    inside
}

#[cfg(test)]
pub(crate) mod tests;
