//! COMMAND_LONG / COMMAND_INT for flight: arm/disarm, mode, takeoff, land, RTL, mission start.
//!
//! The commander decides; we learn its answer from the next `VehicleStatus`. So a command is
//! published, remembered as pending, and acknowledged ACCEPTED once the status shows its effect,
//! DENIED when the commander reports a new refusal or nothing changes within
//! [`ACK_TIMEOUT`]. Commands we do not implement are UNSUPPORTED at once.

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::messages::{Command, FlightMode, LandedState, VehicleStatus};
use mavlink::dialects::ardupilotmega::{COMMAND_ACK_DATA, MavCmd, MavMessage, MavResult};

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
    pub sender: Sender,
}

/// What a command needs to see in the status to count as done.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Effect {
    Armed(bool),
    Mode(FlightMode),
    TakingOff,
}

impl Effect {
    fn seen_in(self, s: &VehicleStatus) -> bool {
        match self {
            Effect::Armed(a) => s.armed == a,
            Effect::Mode(m) => s.mode == m,
            Effect::TakingOff => s.armed && (s.mode == FlightMode::Takeoff || s.landed == LandedState::InAir),
        }
    }
}

#[derive(Debug)]
struct Pending {
    request: CommandRequest,
    effect: Effect,
    deadline: Time,
    issued: Time,
}

/// Flight commands waiting for the commander.
#[derive(Debug, Default)]
pub struct CommandService {
    pending: Vec<Pending>,
    status: Option<VehicleStatus>,
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

impl CommandService {
    /// No command pending.
    pub fn new() -> CommandService {
        CommandService::default()
    }

    /// Handles a flight command; `None` when `request.command` is not a flight command.
    pub fn handle(&mut self, request: CommandRequest, now: Time) -> Option<Outputs> {
        let p = request.params;
        let (command, effect) = match request.command {
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM if p[0] > 0.5 => (Command::Arm, Effect::Armed(true)),
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM => {
                (Command::Disarm { force: p[1] == FORCE_DISARM_MAGIC }, Effect::Armed(false))
            }
            MavCmd::MAV_CMD_DO_SET_MODE => {
                // param1 is base_mode: only MAV_MODE_FLAG_CUSTOM_MODE_ENABLED selects by custom mode.
                let custom = (p[0] as u32 & 1 == 1).then(|| flight_mode(p[1] as u32)).flatten();
                let Some(mode) = custom else {
                    return Some(Outputs::send(ack(&request, MavResult::MAV_RESULT_FAILED)));
                };
                (Command::SetMode(mode), Effect::Mode(mode))
            }
            MavCmd::MAV_CMD_NAV_TAKEOFF => {
                let altitude_m = p[6];
                if !altitude_m.is_finite() || altitude_m <= 0.0 {
                    return Some(Outputs::send(ack(&request, MavResult::MAV_RESULT_DENIED)));
                }
                (Command::Takeoff { altitude_m }, Effect::TakingOff)
            }
            MavCmd::MAV_CMD_NAV_LAND => (Command::Land, Effect::Mode(FlightMode::Land)),
            MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH => {
                (Command::ReturnToLaunch, Effect::Mode(FlightMode::ReturnToLaunch))
            }
            MavCmd::MAV_CMD_MISSION_START => (Command::MissionStart, Effect::Mode(FlightMode::Auto)),
            _ => return None,
        };
        Some(self.submit(request, command, effect, now))
    }

    /// Handles SET_MODE (the legacy message); custom mode only.
    pub fn set_mode(&mut self, sender: Sender, base_mode: u8, custom_mode: u32, now: Time) -> Outputs {
        let request = CommandRequest {
            command: MavCmd::MAV_CMD_DO_SET_MODE,
            params: [f64::from(base_mode), f64::from(custom_mode), 0.0, 0.0, 0.0, 0.0, 0.0],
            sender,
        };
        self.handle(request, now).unwrap_or_default()
    }

    fn submit(&mut self, request: CommandRequest, command: Command, effect: Effect, now: Time) -> Outputs {
        let mut out = Outputs { mav: Vec::new(), graph: vec![ToGraph::Command(command)] };
        if self.status.as_ref().is_some_and(|s| effect.seen_in(s)) {
            out.mav.push(ack(&request, MavResult::MAV_RESULT_ACCEPTED));
            return out;
        }
        self.pending.retain(|p| p.request.command != request.command);
        self.pending.push(Pending { request, effect, deadline: now + ACK_TIMEOUT, issued: now });
        out
    }

    /// The commander's new status: acknowledges what it shows done or refused.
    pub fn on_status(&mut self, status: &VehicleStatus) -> Vec<MavMessage> {
        let refused = status.last_refusal.is_some()
            && self.status.as_ref().map(|s| &s.last_refusal) != Some(&status.last_refusal);
        self.status = Some(status.clone());
        let mut acks = Vec::new();
        self.pending.retain(|p| {
            if p.effect.seen_in(status) {
                acks.push(ack(&p.request, MavResult::MAV_RESULT_ACCEPTED));
                false
            } else if refused && status.time >= p.issued {
                acks.push(ack(&p.request, MavResult::MAV_RESULT_DENIED));
                false
            } else {
                true
            }
        });
        acks
    }

    /// DENIED for every command the commander left unanswered too long.
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

#[cfg(test)]
mod tests {
    use kestrel_proto::messages::MissionProgress;

    use super::*;

    const GCS: Sender = Sender { system_id: 255, component_id: 190 };

    fn request(command: MavCmd, params: [f64; 7]) -> CommandRequest {
        CommandRequest { command, params, sender: GCS }
    }

    fn status(time: f64, armed: bool, mode: FlightMode, refusal: Option<&str>) -> VehicleStatus {
        VehicleStatus {
            time: Time::from_secs_f64(time),
            armed,
            mode,
            landed: LandedState::OnGround,
            failsafe: None,
            mission: MissionProgress::default(),
            last_refusal: refusal.map(str::to_owned),
        }
    }

    fn result(m: &MavMessage) -> (MavCmd, MavResult, u8) {
        match m {
            MavMessage::COMMAND_ACK(a) => (a.command, a.result, a.target_system),
            other => panic!("not an ack: {other:?}"),
        }
    }

    #[test]
    fn arm_is_accepted_when_the_status_shows_it() {
        let mut s = CommandService::new();
        s.on_status(&status(0.0, false, FlightMode::Stabilize, None));
        let out = s
            .handle(
                request(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
                Time::from_secs_f64(1.0),
            )
            .unwrap();
        assert_eq!(out.graph, vec![ToGraph::Command(Command::Arm)]);
        assert!(out.mav.is_empty());
        let acks = s.on_status(&status(1.1, true, FlightMode::Stabilize, None));
        assert_eq!(
            result(&acks[0]),
            (MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, MavResult::MAV_RESULT_ACCEPTED, 255)
        );
    }

    #[test]
    fn a_new_refusal_denies_and_silence_times_out() {
        let mut s = CommandService::new();
        s.on_status(&status(0.0, false, FlightMode::Stabilize, None));
        s.handle(
            request(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
            Time::from_secs_f64(1.0),
        );
        let acks = s.on_status(&status(1.1, false, FlightMode::Stabilize, Some("Arm: no GPS")));
        assert_eq!(result(&acks[0]).1, MavResult::MAV_RESULT_DENIED);

        s.handle(request(MavCmd::MAV_CMD_NAV_LAND, [0.0; 7]), Time::from_secs_f64(2.0));
        assert!(s.on_tick(Time::from_secs_f64(3.0)).is_empty());
        let acks = s.on_tick(Time::from_secs_f64(3.6));
        assert_eq!(result(&acks[0]), (MavCmd::MAV_CMD_NAV_LAND, MavResult::MAV_RESULT_DENIED, 255));
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
        assert_eq!(out.graph, vec![ToGraph::Command(Command::Disarm { force: true })]);
        let out = s
            .handle(request(MavCmd::MAV_CMD_DO_SET_MODE, [1.0, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0]), Time::ZERO)
            .unwrap();
        assert_eq!(out.graph, vec![ToGraph::Command(Command::SetMode(FlightMode::Auto))]);
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
        assert!(s.handle(request(MavCmd::MAV_CMD_DO_FENCE_ENABLE, [0.0; 7]), Time::ZERO).is_none());
    }
}
