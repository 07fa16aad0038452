//! COMMAND_LONG / COMMAND_INT for flight: arm/disarm, mode, takeoff, land, RTL, mission start,
//! home (DO_SET_HOME), the geofence switch (DO_FENCE_ENABLE) and the current mission item
//! (DO_SET_MISSION_CURRENT, range-checked against the stored plan by the caller).
//!
//! The commander decides. A command is published with an id of its own and remembered as
//! pending; the commander's `CommandResult` for that id, which comes within the graph step,
//! makes it ACCEPTED or DENIED (the reason goes out as a STATUSTEXT with the status that
//! records it). A command nobody answers within [`ACK_TIMEOUT`] (a graph without a commander)
//! is DENIED then. Commands we do not implement are UNSUPPORTED at once. Every COMMAND_LONG
//! and COMMAND_INT therefore gets exactly one COMMAND_ACK, a retry its own again.
#![allow(
    deprecated,
    reason = "legacy MAVLink (MISSION_ITEM, REQUEST_DATA_STREAM, SET_MODE, *_INT frames) is still spoken by ground stations and must be accepted"
)]

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::esc::{SAFE_PULSE_MAX_US, SAFE_PULSE_MIN_US};
use kestrel_proto::geo::{Geodetic, LocalFrame, deg_from_e7};
use kestrel_proto::messages::{
    AltitudeFrame, Command, CommandResult, FailureInjection, FailureInjectionResult, FlightMode, MAX_MOTORS,
    MOTOR_TEST_MAX_S, MissionPoint, MotorTestThrottle, OrbitYaw, PositionTarget,
};
use mavlink::MessageData;
use mavlink::dialects::ardupilotmega::{
    AUTOPILOT_VERSION_DATA, COMMAND_ACK_DATA, HOME_POSITION_DATA, MavCmd, MavFrame, MavMessage, MavResult,
    MavSeverity,
};

use super::calibration;
use super::events::statustext;
use super::failure;
use super::mission::MissionService;
use super::telemetry::{Telemetry, home};
use super::{Outputs, Sender, ToGraph};
use crate::modes::flight_mode;

/// How long the commander has to show a command's effect.
pub const ACK_TIMEOUT: Duration = Duration::from_millis(1500);

/// `param2` of MAV_CMD_COMPONENT_ARM_DISARM that forces a disarm in flight (ArduPilot, PX4).
const FORCE_DISARM_MAGIC: f64 = 21196.0;

/// A command as both COMMAND_LONG and COMMAND_INT carry it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CommandRequest {
    pub command: MavCmd,
    /// param1..param7 (COMMAND_INT's x and y as plain numbers, z as param7).
    pub params: [f64; 7],
    /// COMMAND_INT's frame (its x/y are then degE7 for global frames); `None` for COMMAND_LONG.
    pub frame: Option<MavFrame>,
    pub sender: Sender,
}

#[derive(Debug)]
struct Pending {
    request: CommandRequest,
    id: u32,
    deadline: Time,
}

/// Flight commands waiting for the commander's answer.
#[derive(Debug, Default)]
pub struct CommandService {
    pending: Vec<Pending>,
    /// The id of the last command passed on (ids start at 1; 0 means "no answer wanted").
    last_id: u32,
}

/// The COMMAND_ACK for `request`.
pub fn ack(request: &CommandRequest, result: MavResult) -> MavMessage {
    MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
        command: request.command,
        result,
        progress: 0,
        result_param2: 0,
        target_system: request.sender.target_system(),
        target_component: request.sender.component_id,
    })
}

/// What the link's own commands read and change: the telemetry (message intervals, messages on
/// request, the origin), the stored plan (mission items by the ground station's numbers), and
/// the vehicle's identity messages.
pub struct Context<'a> {
    pub telemetry: &'a mut Telemetry,
    pub missions: &'a MissionService,
    pub autopilot_version: MavMessage,
    pub heartbeat: MavMessage,
    /// Whether something in the graph injects failures (declares `SYS_FAILURE_EN`).
    pub failure_injector: bool,
}

impl CommandService {
    /// No command pending.
    pub fn new() -> CommandService {
        CommandService::default()
    }

    /// Every COMMAND_LONG and COMMAND_INT: the one place MAV_CMDs are handled. The link's own
    /// (message intervals and requests, home, mission items by the plan's numbers, points
    /// converted around the origin) are answered here; the flight commands go to the commander
    /// ([`CommandService::handle`]); anything else is UNSUPPORTED.
    pub fn on_command(&mut self, request: CommandRequest, ctx: Context, now: Time) -> Outputs {
        let p = request.params;
        tracing::debug!(command = ?request.command, params = ?p, frame = ?request.frame, from = ?request.sender, "command");
        match request.command {
            MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL => {
                Outputs::send(ack(&request, ctx.telemetry.set_interval(p[0], p[1], now)))
            }
            MavCmd::MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES => Outputs {
                mav: vec![ack(&request, MavResult::MAV_RESULT_ACCEPTED), ctx.autopilot_version.clone()],
                graph: Vec::new(),
            },
            MavCmd::MAV_CMD_REQUEST_MESSAGE => {
                let msg = match whole(p[0], u32::MAX) {
                    Some(AUTOPILOT_VERSION_DATA::ID) => Some(ctx.autopilot_version.clone()),
                    Some(0) => Some(ctx.heartbeat.clone()),
                    Some(id) => ctx.telemetry.build(id, now),
                    None => None,
                };
                match msg {
                    Some(m) => Outputs {
                        mav: vec![ack(&request, MavResult::MAV_RESULT_ACCEPTED), m],
                        graph: Vec::new(),
                    },
                    None => Outputs::send(ack(&request, MavResult::MAV_RESULT_DENIED)),
                }
            }
            MavCmd::MAV_CMD_DO_SET_MISSION_CURRENT => {
                // -1 keeps the item and only resets jump counters, which we do not keep.
                if p[0] == -1.0 {
                    return Outputs::send(ack(&request, MavResult::MAV_RESULT_ACCEPTED));
                }
                let seq = whole(p[0], u16::MAX.into()).and_then(|s| u16::try_from(s).ok());
                // Out of range (no mission included) is FAILED, as the command's definition says.
                let Some(index) = seq.and_then(|s| ctx.missions.commander_index(s)) else {
                    return Outputs::send(ack(&request, MavResult::MAV_RESULT_FAILED));
                };
                let mut out = self.mission_current(request, index, now);
                out.mav.extend(ctx.telemetry.mission_current_if_shown(index));
                out
            }
            // A first item (param1 > 0) starts there; the last item (param2) must be 0 or the
            // plan's last, as we fly to the end: other ranges are DENIED, not flown differently.
            MavCmd::MAV_CMD_MISSION_START if !(p[0] == 0.0 && p[1] == 0.0) => {
                let item = |v: f64| whole(v, u16::MAX.into()).and_then(|s| u16::try_from(s).ok());
                let last = ctx.missions.mission_len().saturating_sub(1);
                let to_end = item(p[1]).is_some_and(|l| l == 0 || usize::from(l) == last);
                match item(p[0]).and_then(|s| ctx.missions.commander_index(s.max(1))) {
                    Some(index) if to_end => self.mission_start_at(request, index, now),
                    _ => Outputs::send(ack(&request, MavResult::MAV_RESULT_DENIED)),
                }
            }
            MavCmd::MAV_CMD_DO_SET_ROI_LOCATION => {
                self.region_of_interest(request, home(&ctx.telemetry.snapshot), now)
            }
            MavCmd::MAV_CMD_DO_REPOSITION => {
                // GUIDED as a ground station sees it: the take-off flown in GUIDED is mode 4 too.
                let guided = ctx
                    .telemetry
                    .snapshot
                    .status
                    .as_ref()
                    .is_some_and(|s| matches!(s.mode, FlightMode::Guided | FlightMode::Takeoff));
                self.reposition(request, home(&ctx.telemetry.snapshot), guided, now)
            }
            MavCmd::MAV_CMD_DO_ORBIT => self.orbit(request, home(&ctx.telemetry.snapshot), now),
            MavCmd::MAV_CMD_GET_HOME_POSITION => match ctx.telemetry.build(HOME_POSITION_DATA::ID, now) {
                Some(home) => Outputs {
                    mav: vec![ack(&request, MavResult::MAV_RESULT_ACCEPTED), home],
                    graph: Vec::new(),
                },
                None => Outputs::send(ack(&request, MavResult::MAV_RESULT_TEMPORARILY_REJECTED)),
            },
            // Sensor calibration: checked here, run by the calibration actor, whose answer is the ACK.
            command if calibration::is_calibration(command) => match calibration::request(&request) {
                Ok(cal) => self.submit_to(request, |id| ToGraph::Calibration { id, request: cal }, now),
                Err((result, reason)) => Outputs {
                    mav: vec![ack(&request, result), statustext(MavSeverity::MAV_SEVERITY_WARNING, &reason)],
                    graph: Vec::new(),
                },
            },
            // Failure injection: checked here, carried out (or refused) by the simulator.
            MavCmd::MAV_CMD_INJECT_FAILURE => match failure::request(&request, ctx.failure_injector) {
                Ok((unit, failure, instance)) => self.submit_to(
                    request,
                    |id| ToGraph::InjectFailure(FailureInjection { time: now, id, unit, failure, instance }),
                    now,
                ),
                Err((result, reason)) => Outputs {
                    mav: vec![ack(&request, result), statustext(MavSeverity::MAV_SEVERITY_WARNING, &reason)],
                    graph: Vec::new(),
                },
            },
            _ => match self.handle(request, now) {
                Some(out) => out,
                None => Outputs::send(ack(&request, MavResult::MAV_RESULT_UNSUPPORTED)),
            },
        }
    }

    /// Handles a flight command; `None` when `request.command` is not a flight command.
    pub fn handle(&mut self, request: CommandRequest, now: Time) -> Option<Outputs> {
        let p = request.params;
        let refuse = |result| Some(Outputs::send(ack(&request, result)));
        let command = match request.command {
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM => match switch(p[0]) {
                Some(true) => Command::Arm,
                Some(false) => Command::Disarm { force: p[1] == FORCE_DISARM_MAGIC },
                None => return refuse(MavResult::MAV_RESULT_DENIED),
            },
            MavCmd::MAV_CMD_DO_SET_MODE => {
                // param1 is base_mode: only MAV_MODE_FLAG_CUSTOM_MODE_ENABLED selects by custom mode.
                let (Some(base), Some(custom)) = (whole(p[0], u8::MAX.into()), whole(p[1], u32::MAX)) else {
                    return refuse(MavResult::MAV_RESULT_DENIED);
                };
                let Some(mode) = (base & 1 == 1).then(|| flight_mode(custom)).flatten() else {
                    tracing::info!(base, custom, "DO_SET_MODE refused: not a custom mode we fly");
                    return refuse(MavResult::MAV_RESULT_FAILED);
                };
                Command::SetMode(mode)
            }
            MavCmd::MAV_CMD_NAV_TAKEOFF => {
                let altitude_m = p[6];
                if !altitude_m.is_finite() || altitude_m <= 0.0 {
                    return refuse(MavResult::MAV_RESULT_DENIED);
                }
                Command::Takeoff { altitude_m }
            }
            MavCmd::MAV_CMD_NAV_LAND => Command::Land,
            // ArduCopter loiters where it is: LOITER, our PosHold (radius and yaw are not flown).
            MavCmd::MAV_CMD_NAV_LOITER_UNLIM => Command::SetMode(FlightMode::PosHold),
            MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH => Command::ReturnToLaunch,
            // param1/param2 (first and last item): 0 and 0 fly the whole mission; a first item
            // is the caller's to map onto the plan (`Vehicle`), and nothing else reaches here.
            MavCmd::MAV_CMD_MISSION_START if p[0] == 0.0 && p[1] == 0.0 => Command::MissionStart,
            MavCmd::MAV_CMD_MISSION_START => return refuse(MavResult::MAV_RESULT_DENIED),
            // ArduCopter's AUTO RTL: on at the nearest DO_LAND_START, FAILED without one.
            MavCmd::MAV_CMD_DO_LAND_START => Command::LandStart,
            // param2 the speed (m/s; param1's airspeed/ground speed is one to a multirotor);
            // -1 and -2 (no change, default) are DENIED rather than read as a speed.
            MavCmd::MAV_CMD_DO_CHANGE_SPEED if p[1].is_finite() && p[1] > 0.0 => {
                Command::ChangeSpeed { speed_m_s: p[1] }
            }
            MavCmd::MAV_CMD_DO_CHANGE_SPEED => return refuse(MavResult::MAV_RESULT_DENIED),
            // param1 the angle (deg), param3 the direction (-1 counter-clockwise, else clockwise)
            // for a relative turn, param4 relative (1) or absolute (0); param2's rate is the
            // controller's yaw rate limit here.
            MavCmd::MAV_CMD_CONDITION_YAW if p[0].is_finite() => match switch(p[3]) {
                Some(false) => Command::Yaw { heading_deg: Some(p[0].rem_euclid(360.0)), relative_deg: None },
                Some(true) => {
                    let sign = if p[2] == -1.0 { -1.0 } else { 1.0 };
                    Command::Yaw { heading_deg: None, relative_deg: Some(sign * p[0]) }
                }
                None => return refuse(MavResult::MAV_RESULT_DENIED),
            },
            MavCmd::MAV_CMD_CONDITION_YAW => return refuse(MavResult::MAV_RESULT_DENIED),
            MavCmd::MAV_CMD_DO_SET_ROI_NONE => Command::RegionOfInterest { position_ned_m: None },
            MavCmd::MAV_CMD_DO_PAUSE_CONTINUE => match switch(p[0]) {
                Some(false) => Command::PauseMission,
                Some(true) => Command::ContinueMission,
                None => return refuse(MavResult::MAV_RESULT_DENIED),
            },
            MavCmd::MAV_CMD_DO_SET_HOME => match home_target(&request) {
                Ok(point) => Command::SetHome { point },
                Err(result) => return refuse(result),
            },
            // param1 1 reboots the autopilot; 0 (nothing), 2 (shut down), 3 (bootloader) and the
            // companion's params are not something this process does. param6 FORCE_REBOOT_MAGIC
            // asks for it while armed, as ArduPilot's `handle_preflight_reboot` reads it.
            MavCmd::MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN if p[0] == 1.0 => {
                Command::Reboot { force: p[5] == FORCE_REBOOT_MAGIC }
            }
            MavCmd::MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN => return refuse(MavResult::MAV_RESULT_UNSUPPORTED),
            MavCmd::MAV_CMD_DO_MOTOR_TEST => match motor_test(&p) {
                Ok(command) => command,
                Err(result) => return refuse(result),
            },
            MavCmd::MAV_CMD_DO_FENCE_ENABLE => match fence_switch(p[0]) {
                Ok(enabled) => Command::SetGeofence { enabled },
                Err(result) => return refuse(result),
            },
            _ => return None,
        };
        Some(self.submit(request, command, now))
    }

    /// MAV_CMD_DO_SET_ROI_LOCATION: keep the nose on a point (params 5-7 as DO_REPOSITION reads
    /// them), converted to NED around the estimator's `origin`.
    pub fn region_of_interest(
        &mut self,
        request: CommandRequest,
        origin: Option<Geodetic>,
        now: Time,
    ) -> Outputs {
        let Ok(Some(point)) = reposition_target(&request) else {
            return Outputs::send(ack(&request, MavResult::MAV_RESULT_DENIED));
        };
        let Some(origin) = origin else {
            return Outputs::send(ack(&request, MavResult::MAV_RESULT_TEMPORARILY_REJECTED));
        };
        let ned = to_ned(origin, &point);
        self.submit(request, Command::RegionOfInterest { position_ned_m: Some(ned) }, now)
    }

    /// MAV_CMD_DO_REPOSITION (QGroundControl's "Go to location", MAVSDK's `goto_location`): fly
    /// to a point, converted to NED around the estimator's `origin`. As in ArduCopter, the
    /// vehicle must be in GUIDED unless param2 carries MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, which
    /// switches to GUIDED first. The ground speed (param1, m/s; negative or NaN: the default) and
    /// the heading (param4, degrees; NaN: the heading held) are flown as the MAVLink definition
    /// and PX4 say; ArduCopter 4.7 ignores both (`handle_command_int_do_reposition`). A speed of zero
    /// or less is the default; an infinite speed or heading is DENIED. Out of GUIDED (`guided`, the last
    /// status) without the change-mode flag it is DENIED here; a target the commander refuses
    /// (beyond the fence) is FAILED, as ArduCopter answers both (`on_answer`). Held by
    /// `tests::reposition_flies_its_speed_and_heading` and
    /// `tests::a_reposition_the_commander_refuses_fails_and_one_out_of_guided_is_denied`.
    pub fn reposition(
        &mut self,
        request: CommandRequest,
        origin: Option<Geodetic>,
        guided: bool,
        now: Time,
    ) -> Outputs {
        let p = request.params;
        let denied = || Outputs::send(ack(&request, MavResult::MAV_RESULT_DENIED));
        let change_mode = match whole(p[1], u8::MAX.into()) {
            Some(flags) => flags & 1 == 1,
            None if p[1].is_nan() => false,
            None => return denied(),
        };
        // MAVSDK's `goto_location` leaves the speed 0: no speed asked, as PX4 reads it.
        let speed_m_s = match p[0] {
            s if s.is_infinite() => return denied(),
            s if s.is_nan() || s <= 0.0 => None,
            s => Some(s),
        };
        let yaw_rad = match p[3] {
            y if y.is_nan() => None,
            y if y.is_finite() => Some(y.to_radians()),
            _ => return denied(),
        };
        let Ok(Some(point)) = reposition_target(&request) else { return denied() };
        if !guided && !change_mode {
            return denied();
        }
        let Some(origin) = origin else {
            return Outputs::send(ack(&request, MavResult::MAV_RESULT_TEMPORARILY_REJECTED));
        };
        let ned = to_ned(origin, &point);
        let mut out = Outputs::none();
        if change_mode {
            out.graph.push(ToGraph::Command(Command::SetMode(FlightMode::Guided)));
        }
        let command = if speed_m_s.is_none() && yaw_rad.is_none() {
            Command::GotoNed { position_ned_m: ned }
        } else {
            Command::PositionTarget(PositionTarget {
                position_ned_m: Some(ned),
                yaw_rad,
                speed_m_s,
                ..PositionTarget::default()
            })
        };
        out.extend(self.submit(request, command, now));
        out
    }

    /// MAV_CMD_DO_ORBIT (QGroundControl's "Orbit", MAVSDK's `do_orbit`): param1 the radius (m,
    /// negative counter-clockwise; NaN the CIRCLE default), param2 the tangential speed (m/s; NaN
    /// the default rate), param3 ORBIT_YAW_BEHAVIOUR (NaN: face the centre), params 5-7 the
    /// centre as DO_REPOSITION reads them (NaN, or COMMAND_INT's INT32_MAX, for latitude and
    /// longitude: here; NaN altitude: the height flown), converted to NED around the
    /// estimator's `origin`. ArduCopter 4.7 answers UNSUPPORTED; we fly it in CIRCLE, as PX4's
    /// Orbit does and as ArduCopter's CIRCLE flies.
    pub fn orbit(&mut self, request: CommandRequest, origin: Option<Geodetic>, now: Time) -> Outputs {
        let p = request.params;
        let denied = || Outputs::send(ack(&request, MavResult::MAV_RESULT_DENIED));
        let radius_m = p[0];
        if radius_m.is_infinite() {
            return denied();
        }
        let speed_m_s = if p[1].is_nan() { None } else { Some(p[1]) };
        // ORBIT_YAW_BEHAVIOUR: 0 front to the centre, 1 initial heading, 2 uncontrolled and
        // 4 RC-controlled (no sticks here: held), 3 tangent to the circle.
        let yaw = match whole(p[2], 4) {
            _ if p[2].is_nan() => OrbitYaw::FaceCentre,
            Some(0) => OrbitYaw::FaceCentre,
            Some(1 | 2 | 4) => OrbitYaw::HoldInitial,
            Some(3) => OrbitYaw::Tangent,
            _ => return denied(),
        };
        let in_deg_e7 = request.frame.is_some();
        let unset = |v: f64| v.is_nan() || (in_deg_e7 && v == f64::from(i32::MAX));
        let (centre_ne_m, centre_down_m) = if unset(p[4]) && unset(p[5]) && p[6].is_nan() {
            (None, None)
        } else {
            let Some(origin) = origin else {
                return Outputs::send(ack(&request, MavResult::MAV_RESULT_TEMPORARILY_REJECTED));
            };
            let ne = if unset(p[4]) || unset(p[5]) {
                None
            } else {
                let mut at = request;
                at.params[6] = if p[6].is_nan() { origin.alt_m } else { p[6] };
                match reposition_target(&at) {
                    Ok(Some(point)) => {
                        let ned = to_ned(origin, &point);
                        Some([ned[0], ned[1]])
                    }
                    _ => return denied(),
                }
            };
            let down = if p[6].is_nan() {
                None
            } else {
                let mut at = request;
                at.params[4] = if in_deg_e7 { origin.lat_deg * 1e7 } else { origin.lat_deg };
                at.params[5] = if in_deg_e7 { origin.lon_deg * 1e7 } else { origin.lon_deg };
                match reposition_target(&at) {
                    Ok(Some(point)) => Some(to_ned(origin, &point)[2]),
                    _ => return denied(),
                }
            };
            (ne, down)
        };
        self.submit(request, Command::Orbit { radius_m, speed_m_s, yaw, centre_ne_m, centre_down_m }, now)
    }

    /// MAV_CMD_MISSION_START from the commander's item `index` (the caller mapped param1, the
    /// ground station's first item, onto the stored plan): that item made current, then the start.
    pub fn mission_start_at(&mut self, request: CommandRequest, index: u32, now: Time) -> Outputs {
        let mut out = Outputs::none();
        out.graph.push(ToGraph::Command(Command::SetMissionCurrent { index }));
        out.extend(self.submit(request, Command::MissionStart, now));
        out
    }

    /// MAV_CMD_DO_SET_MISSION_CURRENT for the commander's item `index`, once the caller has
    /// checked it against the stored plan.
    pub fn mission_current(&mut self, request: CommandRequest, index: u32, now: Time) -> Outputs {
        self.submit(request, Command::SetMissionCurrent { index }, now)
    }

    /// Handles SET_MODE (the legacy message); custom mode only.
    pub fn set_mode(&mut self, sender: Sender, base_mode: u8, custom_mode: u32, now: Time) -> Outputs {
        let request = CommandRequest {
            command: MavCmd::MAV_CMD_DO_SET_MODE,
            params: [f64::from(base_mode), f64::from(custom_mode), 0.0, 0.0, 0.0, 0.0, 0.0],
            frame: None,
            sender,
        };
        self.handle(request, now).unwrap_or_default()
    }

    /// Passes `command` on with a new id and waits for its result.
    fn submit(&mut self, request: CommandRequest, command: Command, now: Time) -> Outputs {
        self.submit_to(request, |id| ToGraph::Request { id, command }, now)
    }

    /// Passes on what `to_graph` makes of a new id and waits for the answer to that id.
    fn submit_to(
        &mut self,
        request: CommandRequest,
        to_graph: impl FnOnce(u32) -> ToGraph,
        now: Time,
    ) -> Outputs {
        self.last_id = self.last_id.checked_add(1).unwrap_or(1);
        let id = self.last_id;
        self.pending.push(Pending { request, id, deadline: now + ACK_TIMEOUT });
        Outputs { mav: Vec::new(), graph: vec![to_graph(id)] }
    }

    /// The commander's answer: the COMMAND_ACK of the command it answers (none for an id we are
    /// not waiting for: one timed out already, or another link's).
    pub fn on_result(&mut self, result: &CommandResult) -> Option<MavMessage> {
        self.on_answer(result.id, result.refusal.is_some())
    }

    /// The answer to the command passed on with `id` (the commander's or the calibration's).
    /// A refused DO_REPOSITION is FAILED, as ArduCopter answers a GUIDED destination it will not
    /// fly (beyond the fence: `tests/gcs_fence.rs`), and so is a refused DO_LAND_START, as
    /// ArduCopter answers one without a landing sequence (the same test); any other refusal is
    /// DENIED.
    pub fn on_answer(&mut self, id: u32, refused: bool) -> Option<MavMessage> {
        let reposition = self.pending.iter().any(|p| {
            p.id == id
                && matches!(p.request.command, MavCmd::MAV_CMD_DO_REPOSITION | MavCmd::MAV_CMD_DO_LAND_START)
        });
        let answer = match (refused, reposition) {
            (false, _) => MavResult::MAV_RESULT_ACCEPTED,
            (true, true) => MavResult::MAV_RESULT_FAILED,
            (true, false) => MavResult::MAV_RESULT_DENIED,
        };
        self.acknowledge(id, answer)
    }

    /// The injector's answer to a failure injection: its COMMAND_ACK and the STATUSTEXT saying
    /// what was injected or why not (nothing for an id we are not waiting for).
    pub fn on_injection_result(&mut self, result: &FailureInjectionResult) -> Vec<MavMessage> {
        let (answer, text) = failure::answer(result);
        self.acknowledge(result.id, answer).map_or_else(Vec::new, |ack| vec![ack, text])
    }

    /// The COMMAND_ACK with `result` of the pending command `id`, which is then done.
    fn acknowledge(&mut self, id: u32, result: MavResult) -> Option<MavMessage> {
        let i = self.pending.iter().position(|p| p.id == id)?;
        let pending = self.pending.swap_remove(i);
        Some(ack(&pending.request, result))
    }

    /// DENIED for every command left unanswered too long.
    pub fn on_tick(&mut self, now: Time) -> Vec<MavMessage> {
        let mut acks = Vec::new();
        self.pending.retain(|p| {
            let expired = now >= p.deadline;
            if expired {
                acks.push(ack(&p.request, MavResult::MAV_RESULT_DENIED));
            }
            !expired
        });
        acks
    }
}

/// MAV_CMD_DO_SET_HOME's target: `None` for the vehicle's position (param1 = 1, or latitude and
/// longitude both 0 as ArduPilot reads them), else the point in params 5-7. COMMAND_LONG carries
/// degrees and metres above mean sea level; COMMAND_INT degE7 in x/y, and its frame says what z
/// is measured from. What is not a position is DENIED here; whether it can be home (an origin,
/// its distance) the commander decides.
fn home_target(request: &CommandRequest) -> Result<Option<MissionPoint>, MavResult> {
    let p = request.params;
    match switch(p[0]) {
        Some(true) => return Ok(None),
        Some(false) => {}
        None => return Err(MavResult::MAV_RESULT_DENIED),
    }
    let (frame, in_deg_e7) = match request.frame {
        None => (AltitudeFrame::Amsl, false),
        Some(MavFrame::MAV_FRAME_GLOBAL | MavFrame::MAV_FRAME_GLOBAL_INT) => (AltitudeFrame::Amsl, true),
        Some(MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT | MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT) => {
            (AltitudeFrame::RelativeHome, true)
        }
        Some(_) => return Err(MavResult::MAV_RESULT_DENIED),
    };
    let deg = |v: f64| if in_deg_e7 { deg_from_e7(v) } else { v };
    let (lat_deg, lon_deg, alt_m) = (deg(p[4]), deg(p[5]), p[6]);
    if lat_deg == 0.0 && lon_deg == 0.0 {
        return Ok(None);
    }
    if !(lat_deg.abs() <= 90.0 && lon_deg.abs() <= 180.0 && alt_m.is_finite()) {
        return Err(MavResult::MAV_RESULT_DENIED);
    }
    Ok(Some(MissionPoint { lat_deg, lon_deg, alt_m, frame }))
}

/// `point` in NED around `origin` (m); a relative altitude is above the origin.
fn to_ned(origin: Geodetic, point: &MissionPoint) -> [f64; 3] {
    let alt_m = match point.frame {
        AltitudeFrame::RelativeHome => origin.alt_m + point.alt_m,
        _ => point.alt_m,
    };
    LocalFrame::new(origin).to_ned(Geodetic { lat_deg: point.lat_deg, lon_deg: point.lon_deg, alt_m })
}

/// DO_REPOSITION's point: params 5-7 as DO_SET_HOME reads them (degrees or degE7 by message,
/// the altitude by frame), where latitude and longitude both 0 mean no point at all.
fn reposition_target(request: &CommandRequest) -> Result<Option<MissionPoint>, MavResult> {
    let mut as_home = *request;
    as_home.params[0] = 0.0;
    home_target(&as_home)
}

/// MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN's param6 that asks for a reboot while armed (ArduPilot's
/// `magic_force_reboot_value`); the commander still refuses it in the air.
const FORCE_REBOOT_MAGIC: f64 = 20190226.0;

/// MAV_CMD_DO_MOTOR_TEST's params as ArduCopter's `mavlink_motor_test_start` reads them:
/// param1 the motor (1-based, in the test order, at most `MAX_MOTORS`), param2 the throttle
/// type — MOTOR_TEST_THROTTLE_PERCENT (0: param3 0..=100 %) or MOTOR_TEST_THROTTLE_PWM (1:
/// param3 a pulse within `esc::SAFE_PULSE_MIN_US..=SAFE_PULSE_MAX_US`, ArduCopter's
/// `MOTOR_TEST_PWM_MIN/MAX`); pilot pass-through (2) and compass calibration (3) are
/// UNSUPPORTED, as no radio throttle or per-motor compass learning is here — param4 the time
/// (s, > 0; above `MOTOR_TEST_MAX_S` cut to it, as ArduCopter does), param5 how many motors in
/// sequence (0 counts as 1; past the last motor DENIED). param6 (order) is ignored, as
/// ArduCopter ignores it. What is out of range is DENIED.
fn motor_test(p: &[f64; 7]) -> Result<Command, MavResult> {
    let max = MAX_MOTORS as u32;
    let first = whole(p[0], max).filter(|&m| m >= 1).ok_or(MavResult::MAV_RESULT_DENIED)?;
    let throttle = match whole(p[1], 3) {
        Some(0) if (0.0..=100.0).contains(&p[2]) => MotorTestThrottle::Share(p[2] / 100.0),
        Some(1) if (SAFE_PULSE_MIN_US..=SAFE_PULSE_MAX_US).contains(&p[2]) => {
            MotorTestThrottle::PulseUs(p[2])
        }
        Some(2 | 3) => return Err(MavResult::MAV_RESULT_UNSUPPORTED),
        _ => return Err(MavResult::MAV_RESULT_DENIED),
    };
    if !(p[3].is_finite() && p[3] > 0.0) {
        return Err(MavResult::MAV_RESULT_DENIED);
    }
    let count = whole(p[4], max).ok_or(MavResult::MAV_RESULT_DENIED)?.max(1);
    if first + count - 1 > max {
        return Err(MavResult::MAV_RESULT_DENIED);
    }
    // Both at most MAX_MOTORS (8): they fit.
    Ok(Command::MotorTest {
        first: first as u8,
        count: count as u8,
        throttle,
        duration_s: p[3].min(MOTOR_TEST_MAX_S),
    })
}

/// MAV_CMD_DO_FENCE_ENABLE's param1: 0 off, 1 on. 2 (ArduPilot: disable the floor only) is
/// UNSUPPORTED, as our fence has no floor (minimum altitude) to disable; anything else DENIED.
fn fence_switch(param1: f64) -> Result<bool, MavResult> {
    match switch(param1) {
        Some(enabled) => Ok(enabled),
        None if param1 == 2.0 => Err(MavResult::MAV_RESULT_UNSUPPORTED),
        None => Err(MavResult::MAV_RESULT_DENIED),
    }
}

/// A parameter that switches something off or on: exactly 0 or exactly 1, as PX4 and ArduPilot
/// read MAV_CMD_COMPONENT_ARM_DISARM's param1. Anything else — 0.5, 2, NaN, ±inf — is `None`,
/// so a corrupted or careless command is refused instead of being read as one of the two.
pub(crate) fn switch(param: f64) -> Option<bool> {
    if param == 0.0 {
        Some(false)
    } else if param == 1.0 {
        Some(true)
    } else {
        None
    }
}

/// A parameter that carries a whole number in `0..=max` (a mode number, a message id): `None`
/// for fractions, negatives, values past `max`, NaN and ±inf, never truncated into range.
pub(crate) fn whole(param: f64, max: u32) -> Option<u32> {
    (param.fract() == 0.0 && (0.0..=f64::from(max)).contains(&param)).then_some(param as u32)
}

#[cfg(test)]
mod tests;
