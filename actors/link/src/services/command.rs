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
use kestrel_proto::geo::{Geodetic, LocalFrame, deg_from_e7};
use kestrel_proto::messages::{
    AltitudeFrame, Command, CommandResult, FailureInjection, FailureInjectionResult, FlightMode, MissionPoint,
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
            MavCmd::MAV_CMD_DO_REPOSITION => self.reposition(request, home(&ctx.telemetry.snapshot), now),
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
    /// switches to GUIDED first. The speed (param1) and yaw (param4) are not flown: the leg
    /// keeps the guided speed and the heading held.
    pub fn reposition(&mut self, request: CommandRequest, origin: Option<Geodetic>, now: Time) -> Outputs {
        let p = request.params;
        let denied = || Outputs::send(ack(&request, MavResult::MAV_RESULT_DENIED));
        let change_mode = match whole(p[1], u8::MAX.into()) {
            Some(flags) => flags & 1 == 1,
            None if p[1].is_nan() => false,
            None => return denied(),
        };
        let Ok(Some(point)) = reposition_target(&request) else { return denied() };
        let Some(origin) = origin else {
            return Outputs::send(ack(&request, MavResult::MAV_RESULT_TEMPORARILY_REJECTED));
        };
        let ned = to_ned(origin, &point);
        let mut out = Outputs::none();
        if change_mode {
            out.graph.push(ToGraph::Command(Command::SetMode(FlightMode::Guided)));
        }
        out.extend(self.submit(request, Command::GotoNed { position_ned_m: ned }, now));
        out
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
    pub fn on_answer(&mut self, id: u32, refused: bool) -> Option<MavMessage> {
        let answer = if !refused { MavResult::MAV_RESULT_ACCEPTED } else { MavResult::MAV_RESULT_DENIED };
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
mod tests {
    use super::*;

    const GCS: Sender = Sender { system_id: 255, component_id: 190 };

    fn request(command: MavCmd, params: [f64; 7]) -> CommandRequest {
        CommandRequest { command, params, frame: None, sender: GCS }
    }

    fn result(m: &MavMessage) -> (MavCmd, MavResult, u8) {
        match m {
            MavMessage::COMMAND_ACK(a) => (a.command, a.result, a.target_system),
            other => panic!("not an ack: {other:?}"),
        }
    }

    fn answer(id: u32, command: Command, refusal: Option<&str>) -> CommandResult {
        CommandResult { time: Time::ZERO, id, command, refusal: refusal.map(str::to_owned) }
    }

    const ARM: [f64; 7] = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];

    #[test]
    fn a_command_is_acknowledged_by_the_commanders_result_for_its_id() {
        let mut s = CommandService::new();
        let out = s.handle(request(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, ARM), Time::ZERO).expect("handled");
        assert_eq!(out.graph, vec![ToGraph::Request { id: 1, command: Command::Arm }]);
        assert!(out.mav.is_empty(), "no answer before the commander's");
        assert!(s.on_result(&answer(7, Command::Arm, None)).is_none(), "not an id we wait for");
        let ack = s.on_result(&answer(1, Command::Arm, None)).expect("ack");
        assert_eq!(result(&ack), (MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, MavResult::MAV_RESULT_ACCEPTED, 255));
        assert!(s.on_result(&answer(1, Command::Arm, None)).is_none(), "one ACK per command");
    }

    #[test]
    fn every_retry_of_a_refused_command_gets_its_own_denial_and_silence_times_out() {
        let mut s = CommandService::new();
        // MAVSDK resends after 0.5 s without an ACK; the commander refuses each alike.
        for (n, t) in [(1, 0.0), (2, 0.5), (3, 1.0)] {
            let out = s
                .handle(request(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, ARM), Time::from_secs_f64(t))
                .expect("handled");
            assert_eq!(out.graph, vec![ToGraph::Request { id: n, command: Command::Arm }]);
        }
        for id in [1, 2, 3] {
            let ack = s.on_result(&answer(id, Command::Arm, Some("arming refused: no GPS"))).expect("ack");
            assert_eq!(result(&ack).1, MavResult::MAV_RESULT_DENIED);
        }
        s.handle(request(MavCmd::MAV_CMD_NAV_LAND, [0.0; 7]), Time::from_secs_f64(2.0));
        assert!(s.on_tick(Time::from_secs_f64(3.0)).is_empty());
        let acks = s.on_tick(Time::from_secs_f64(3.6));
        assert_eq!(result(&acks[0]), (MavCmd::MAV_CMD_NAV_LAND, MavResult::MAV_RESULT_DENIED, 255));
        assert!(s.on_tick(Time::from_secs_f64(9.0)).is_empty(), "answered once");
    }

    #[test]
    fn force_disarm_modes_and_bad_takeoff() {
        let mut s = CommandService::new();
        let out = s
            .handle(
                request(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, [0.0, 21196.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
                Time::ZERO,
            )
            .unwrap();
        assert_eq!(graph(&out), Some(Command::Disarm { force: true }));
        let out = s
            .handle(request(MavCmd::MAV_CMD_DO_SET_MODE, [1.0, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0]), Time::ZERO)
            .unwrap();
        assert_eq!(graph(&out), Some(Command::SetMode(FlightMode::Auto)));
        let out = s
            .handle(request(MavCmd::MAV_CMD_DO_SET_MODE, [1.0, 77.0, 0.0, 0.0, 0.0, 0.0, 0.0]), Time::ZERO)
            .unwrap();
        assert_eq!(result(&out.mav[0]).1, MavResult::MAV_RESULT_FAILED);
        let out = s
            .handle(
                request(MavCmd::MAV_CMD_NAV_TAKEOFF, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, f64::NAN]),
                Time::ZERO,
            )
            .unwrap();
        assert_eq!(result(&out.mav[0]).1, MavResult::MAV_RESULT_DENIED);
        assert!(out.graph.is_empty());
        assert!(s.handle(request(MavCmd::MAV_CMD_DO_PARACHUTE, [0.0; 7]), Time::ZERO).is_none());
    }

    fn graph(out: &Outputs) -> Option<Command> {
        out.graph.iter().find_map(|g| match g {
            ToGraph::Request { command, .. } => Some(*command),
            _ => None,
        })
    }

    #[test]
    fn arm_disarm_takes_exactly_zero_or_one_and_refuses_the_rest() {
        let mut s = CommandService::new();
        for param1 in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 0.5, 0.9, 2.0, -1.0, 1e30] {
            for param2 in [0.0, 21196.0] {
                let out = s
                    .handle(
                        request(
                            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                            [param1, param2, 0.0, 0.0, 0.0, 0.0, 0.0],
                        ),
                        Time::ZERO,
                    )
                    .expect("handled");
                assert!(out.graph.is_empty(), "param1 {param1} param2 {param2} reached the commander");
                assert_eq!(result(&out.mav[0]).1, MavResult::MAV_RESULT_DENIED, "param1 {param1}");
            }
        }
        let disarm = s
            .handle(
                request(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, [0.0, f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0]),
                Time::ZERO,
            )
            .expect("handled");
        assert_eq!(graph(&disarm), Some(Command::Disarm { force: false }), "NaN is not the force code");
    }

    #[test]
    fn mode_and_mission_start_refuse_what_is_not_a_whole_number() {
        let mut s = CommandService::new();
        for params in [
            [f64::NAN, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            [1.0, f64::INFINITY, 0.0, 0.0, 0.0, 0.0, 0.0],
            [1.0, 3.5, 0.0, 0.0, 0.0, 0.0, 0.0],
            [1.0, -3.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            [257.0, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            [1.0, 4_294_967_299.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        ] {
            let out = s.handle(request(MavCmd::MAV_CMD_DO_SET_MODE, params), Time::ZERO).expect("handled");
            assert!(out.graph.is_empty(), "{params:?}");
            assert_eq!(result(&out.mav[0]).1, MavResult::MAV_RESULT_DENIED, "{params:?}");
        }
        for first in [f64::NAN, f64::INFINITY, 2.0] {
            let p = [first, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
            let out = s.handle(request(MavCmd::MAV_CMD_MISSION_START, p), Time::ZERO).expect("handled");
            assert!(out.graph.is_empty(), "{first}");
            assert_eq!(result(&out.mav[0]).1, MavResult::MAV_RESULT_DENIED);
        }
        for param1 in [f64::NAN, 0.5, f64::NEG_INFINITY] {
            let p = [param1, 0.0, 0.0, 0.0, 6.8, 79.9, 30.0];
            let out = s.handle(request(MavCmd::MAV_CMD_DO_SET_HOME, p), Time::ZERO).expect("handled");
            assert!(out.graph.is_empty(), "{param1}");
            let p = [param1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
            let out = s.handle(request(MavCmd::MAV_CMD_DO_FENCE_ENABLE, p), Time::ZERO).expect("handled");
            assert_eq!(result(&out.mav[0]).1, MavResult::MAV_RESULT_DENIED, "{param1}");
        }
    }

    #[test]
    fn set_home_reads_long_and_int_forms_and_denies_what_is_not_a_position() {
        let mut s = CommandService::new();
        let here =
            s.handle(request(MavCmd::MAV_CMD_DO_SET_HOME, [1.0, 0.0, 0.0, 0.0, 6.8, 79.9, 30.0]), Time::ZERO);
        assert_eq!(graph(&here.expect("handled")), Some(Command::SetHome { point: None }));
        let long =
            s.handle(request(MavCmd::MAV_CMD_DO_SET_HOME, [0.0, 0.0, 0.0, 0.0, 6.8, 79.9, 30.0]), Time::ZERO);
        let Some(Command::SetHome { point: Some(p) }) = graph(&long.expect("handled")) else {
            panic!("no point")
        };
        assert_eq!((p.lat_deg, p.lon_deg, p.alt_m, p.frame), (6.8, 79.9, 30.0, AltitudeFrame::Amsl));
        let int = CommandRequest {
            frame: Some(MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT),
            ..request(MavCmd::MAV_CMD_DO_SET_HOME, [0.0, 0.0, 0.0, 0.0, 67_971_000.0, 799_017_000.0, 5.0])
        };
        let Some(Command::SetHome { point: Some(p) }) = graph(&s.handle(int, Time::ZERO).expect("handled"))
        else {
            panic!("no point")
        };
        assert!((p.lat_deg - 6.7971).abs() < 1e-9 && (p.lon_deg - 79.9017).abs() < 1e-9, "{p:?}");
        assert_eq!(p.frame, AltitudeFrame::RelativeHome);
        for (params, frame) in [
            ([0.0, 0.0, 0.0, 0.0, 95.0, 79.9, 30.0], None),
            ([0.0, 0.0, 0.0, 0.0, 6.8, 79.9, f64::NAN], None),
            ([0.0, 0.0, 0.0, 0.0, 68e6, 799e6, 5.0], Some(MavFrame::MAV_FRAME_LOCAL_NED)),
        ] {
            let bad = CommandRequest { frame, ..request(MavCmd::MAV_CMD_DO_SET_HOME, params) };
            let out = s.handle(bad, Time::ZERO).expect("handled");
            assert_eq!(result(&out.mav[0]).1, MavResult::MAV_RESULT_DENIED, "{params:?}");
            assert!(out.graph.is_empty());
        }
    }

    #[test]
    fn fence_enable_switches_and_refuses_the_floor_and_nonsense() {
        let mut s = CommandService::new();
        let off = s.handle(request(MavCmd::MAV_CMD_DO_FENCE_ENABLE, [0.0; 7]), Time::ZERO).expect("handled");
        assert_eq!(graph(&off), Some(Command::SetGeofence { enabled: false }));
        for (param1, want) in [(2.0, MavResult::MAV_RESULT_UNSUPPORTED), (7.0, MavResult::MAV_RESULT_DENIED)]
        {
            let p = [param1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
            let out = s.handle(request(MavCmd::MAV_CMD_DO_FENCE_ENABLE, p), Time::ZERO).expect("handled");
            assert_eq!(result(&out.mav[0]).1, want);
            assert!(out.graph.is_empty());
        }
    }

    #[test]
    fn change_speed_and_pause_continue_take_their_parameters_exactly() {
        let mut s = CommandService::new();
        let speed = |s: &mut CommandService, p2: f64| {
            s.handle(
                request(MavCmd::MAV_CMD_DO_CHANGE_SPEED, [1.0, p2, -1.0, 0.0, 0.0, 0.0, 0.0]),
                Time::ZERO,
            )
            .expect("handled")
        };
        assert_eq!(graph(&speed(&mut s, 3.5)), Some(Command::ChangeSpeed { speed_m_s: 3.5 }));
        for bad in [-1.0, -2.0, 0.0, f64::NAN, f64::INFINITY] {
            let out = speed(&mut s, bad);
            assert!(out.graph.is_empty(), "{bad}");
            assert_eq!(result(&out.mav[0]).1, MavResult::MAV_RESULT_DENIED, "{bad}");
        }
        let pause = |s: &mut CommandService, p1: f64| {
            s.handle(
                request(MavCmd::MAV_CMD_DO_PAUSE_CONTINUE, [p1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
                Time::ZERO,
            )
            .expect("handled")
        };
        assert_eq!(graph(&pause(&mut s, 0.0)), Some(Command::PauseMission));
        assert_eq!(graph(&pause(&mut s, 1.0)), Some(Command::ContinueMission));
        assert_eq!(result(&pause(&mut s, 0.5).mav[0]).1, MavResult::MAV_RESULT_DENIED);
        let yaw = |s: &mut CommandService, p: [f64; 7]| {
            s.handle(request(MavCmd::MAV_CMD_CONDITION_YAW, p), Time::ZERO).expect("handled")
        };
        let absolute = yaw(&mut s, [450.0, 20.0, 1.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(graph(&absolute), Some(Command::Yaw { heading_deg: Some(90.0), relative_deg: None }));
        let left = yaw(&mut s, [30.0, 20.0, -1.0, 1.0, 0.0, 0.0, 0.0]);
        assert_eq!(graph(&left), Some(Command::Yaw { heading_deg: None, relative_deg: Some(-30.0) }));
        for bad in [[f64::NAN, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0], [10.0, 0.0, 1.0, 0.5, 0.0, 0.0, 0.0]] {
            assert_eq!(result(&yaw(&mut s, bad).mav[0]).1, MavResult::MAV_RESULT_DENIED, "{bad:?}");
        }
    }
}
