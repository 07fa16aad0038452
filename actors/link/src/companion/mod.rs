//! Kestrel as a companion computer beside a flight controller (ArduPilot or PX4): the
//! [`Station`] behind the hub when the link is the companion's (`companion_link`,
//! [`crate::companion_actor`]).
//!
//! * It is not an autopilot: its HEARTBEAT says MAV_TYPE_ONBOARD_CONTROLLER and
//!   MAV_AUTOPILOT_INVALID, from component [`DEFAULT_COMPONENT_ID`] (MAV_COMP_ID_OBSTACLE_AVOIDANCE)
//!   of the flight controller's system, learnt from the first autopilot heartbeat heard on the
//!   flight controller's endpoint; until then it sends nothing. No autopilot service answers
//!   (parameters, missions, commands): a command addressed to it alone is answered
//!   MAV_RESULT_UNSUPPORTED, once.
//! * It reads the flight controller's state ([`fc_state`]), asks for the streams it needs
//!   ([`stream_requests`]), aligns clocks by TIMESYNC ([`fc_clock`]) and sends OBSTACLE_DISTANCE
//!   ([`obstacle_out`]).
//! * Routing is the hub's (mavlink-router's rules): ground stations on the other endpoints see
//!   the flight controller's frames and ours, their commands reach the flight controller, signed
//!   frames pass unchanged; what is addressed to this component alone goes nowhere else.

pub mod fc_clock;
pub mod fc_modes;
pub mod fc_state;
pub mod obstacle_out;
pub mod stream_requests;

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::messages::{NavState, ObstacleSectors, VehicleStatus};
use mavlink::Message;
use mavlink::dialects::ardupilotmega::{
    COMMAND_ACK_DATA, HEARTBEAT_DATA, MavAutopilot, MavMessage, MavModeFlag, MavResult, MavState, MavType,
};

use crate::frame::Frame;
use crate::services::Sender;
use crate::station::{EndpointIndex, Station, StationOut};
use fc_clock::FcClock;
use fc_state::FcState;
use obstacle_out::ObstacleOut;
use stream_requests::StreamRequests;

/// MAV_COMP_ID_OBSTACLE_AVOIDANCE: the component ArduPilot and ground stations expect an
/// obstacle-avoidance companion to speak as.
pub const DEFAULT_COMPONENT_ID: u8 = 196;
/// MAV_COMP_ID_AUTOPILOT1: the flight controller's component.
pub const AUTOPILOT_COMPONENT_ID: u8 = 1;
/// The endpoint of the flight controller: the first of the companion's endpoint list.
pub const FC_ENDPOINT: EndpointIndex = 0;
/// TIMESYNC requests while the window fills, then once a second (mavlink.io suggests 1 Hz
/// and more while starting).
const TIMESYNC_FAST: Duration = Duration::from_millis(100);
const TIMESYNC_SLOW: Duration = Duration::from_secs(1);

/// The flight controller as its heartbeat announced it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlightController {
    pub system_id: u8,
    pub component_id: u8,
    pub autopilot: MavAutopilot,
}

/// What the companion publishes into the graph.
#[derive(Clone, Debug, PartialEq)]
pub enum CompanionOut {
    /// The flight controller's state, on our clock (port `nav_state`).
    Nav(Box<NavState>),
    /// Its mode, armed state and home (port `vehicle_status`).
    Status(Box<VehicleStatus>),
}

/// The companion computer as a MAVLink component.
#[derive(Debug)]
pub struct Companion {
    component_id: u8,
    fc: Option<FlightController>,
    clock: FcClock,
    state: FcState,
    obstacles: ObstacleOut,
    streams: StreamRequests,
    last_timesync: Option<Time>,
    /// Commands addressed to us alone (answered UNSUPPORTED).
    pub unsupported: u64,
}

impl Companion {
    /// A companion speaking as `component_id` once it has heard its flight controller.
    pub fn new(component_id: u8) -> Companion {
        Companion {
            component_id,
            fc: None,
            clock: FcClock::new(),
            state: FcState::new(),
            obstacles: ObstacleOut::new(),
            streams: StreamRequests::new(),
            last_timesync: None,
            unsupported: 0,
        }
    }

    /// The flight controller, once heard.
    pub fn flight_controller(&self) -> Option<FlightController> {
        self.fc
    }

    /// The clock alignment with the flight controller.
    pub fn fc_clock(&self) -> &FcClock {
        &self.clock
    }

    /// New obstacle sectors captured at `time` (a depth grid's, or the proximity actor's).
    pub fn on_sectors(&mut self, time: Time, sectors: &ObstacleSectors) {
        self.obstacles.on_sectors(time, sectors);
    }

    /// OBSTACLE_DISTANCE sets not sent because they were stale, and because the clocks were
    /// not aligned.
    pub fn obstacle_counters(&self) -> (u64, u64) {
        (self.obstacles.stale, self.obstacles.unsynced)
    }

    fn on_fc_message(&mut self, sender: Sender, msg: &MavMessage, now: Time) -> StationOut<CompanionOut> {
        let mut out = StationOut::default();
        let Some(fc) = self.fc else { return out };
        self.streams.heard(msg.message_id(), now);
        if let MavMessage::TIMESYNC(t) = msg {
            self.clock.on_timesync(t, now);
            return out;
        }
        if sender.component_id != fc.component_id {
            return out;
        }
        let published = self.state.on_message(msg, fc.autopilot, &mut self.clock, now);
        out.graph.extend(published.nav.map(|n| CompanionOut::Nav(Box::new(n))));
        out.graph.extend(published.status.map(|s| CompanionOut::Status(Box::new(s))));
        out
    }

    /// A command addressed to this component alone: answered once, UNSUPPORTED (it offers
    /// no command; never ACK what we do not do).
    fn refuse_command(&mut self, sender: Sender, msg: &MavMessage) -> Option<MavMessage> {
        let command = match msg {
            MavMessage::COMMAND_LONG(c) if self.addressed(c.target_system, c.target_component) => c.command,
            MavMessage::COMMAND_INT(c) if self.addressed(c.target_system, c.target_component) => c.command,
            _ => return None,
        };
        self.unsupported += 1;
        Some(MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
            command,
            result: MavResult::MAV_RESULT_UNSUPPORTED,
            target_system: sender.target_system(),
            target_component: sender.component_id,
            ..Default::default()
        }))
    }

    fn addressed(&self, system: u8, component: u8) -> bool {
        self.fc.is_some_and(|fc| fc.system_id == system) && component == self.component_id
    }
}

/// Whether a heartbeat is a flight controller's (not a ground station's, a camera's, ...).
fn is_autopilot(hb: &HEARTBEAT_DATA) -> bool {
    hb.autopilot != MavAutopilot::MAV_AUTOPILOT_INVALID
        && !matches!(
            hb.mavtype,
            MavType::MAV_TYPE_GCS
                | MavType::MAV_TYPE_ONBOARD_CONTROLLER
                | MavType::MAV_TYPE_GIMBAL
                | MavType::MAV_TYPE_CAMERA
        )
}

impl Station for Companion {
    type Graph = CompanionOut;

    fn identity(&self) -> Option<(u8, u8)> {
        self.fc.map(|fc| (fc.system_id, self.component_id))
    }

    /// Our system id is the flight controller's: only frames from our own component are ours.
    fn claims_ours(&self, frame: &Frame) -> bool {
        self.fc.is_some_and(|fc| frame.system_id == u32::from(fc.system_id))
            && frame.component_id == self.component_id
    }

    fn consumes(&self, target_system: u8, target_component: u8) -> bool {
        self.addressed(target_system, target_component)
    }

    fn is_for_us(&self, msg: &MavMessage) -> bool {
        matches!((msg.target_system_id(), msg.target_component_id()), (Some(s), Some(c)) if self.addressed(s, c))
    }

    fn receive(
        &mut self,
        endpoint: EndpointIndex,
        sender: Sender,
        _frame: &Frame,
        msg: Option<&MavMessage>,
        now: Time,
    ) -> StationOut<CompanionOut> {
        let Some(msg) = msg else { return StationOut::default() };
        if let Some(ack) = self.refuse_command(sender, msg) {
            return StationOut { mav: vec![ack], ..StationOut::default() };
        }
        if endpoint != FC_ENDPOINT {
            return StationOut::default();
        }
        if self.fc.is_none()
            && let MavMessage::HEARTBEAT(hb) = msg
            && is_autopilot(hb)
            && sender.component_id == AUTOPILOT_COMPONENT_ID
            && let Ok(system_id) = u8::try_from(sender.system_id)
        {
            let fc =
                FlightController { system_id, component_id: sender.component_id, autopilot: hb.autopilot };
            tracing::info!(
                ?fc,
                "flight controller heard: the companion speaks as its component {}",
                self.component_id
            );
            self.fc = Some(fc);
        }
        match self.fc {
            Some(fc) if sender.system_id == u32::from(fc.system_id) => self.on_fc_message(sender, msg, now),
            _ => StationOut::default(),
        }
    }

    fn heartbeat(&self) -> Option<MavMessage> {
        self.fc?;
        Some(MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: 0,
            mavtype: MavType::MAV_TYPE_ONBOARD_CONTROLLER,
            autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
            base_mode: MavModeFlag::empty(),
            system_status: MavState::MAV_STATE_ACTIVE,
            mavlink_version: 3,
        }))
    }

    fn on_tick(&mut self, now: Time) -> StationOut<CompanionOut> {
        let mut out = StationOut::default();
        let Some(fc) = self.fc else { return out };
        let target = (fc.system_id, fc.component_id);
        let period = if self.clock.samples() < fc_clock::WINDOW / 2 { TIMESYNC_FAST } else { TIMESYNC_SLOW };
        if self.last_timesync.is_none_or(|t| now.saturating_since(t) >= period) {
            self.last_timesync = Some(now);
            out.mav.push(MavMessage::TIMESYNC(self.clock.request(now, target)));
        }
        out.mav.extend(self.streams.due(now, target));
        if let Some(o) = self.obstacles.due(now, &self.clock) {
            out.mav.push(MavMessage::OBSTACLE_DISTANCE(o));
        }
        out.graph.extend(self.state.on_tick(now).map(|n| CompanionOut::Nav(Box::new(n))));
        out
    }

    fn unhandled(&self) -> u64 {
        self.unsupported
    }

    fn signing_store_id(&self) -> u8 {
        self.component_id
    }
}

#[cfg(test)]
mod tests;
