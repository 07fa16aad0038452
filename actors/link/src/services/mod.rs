//! The vehicle side of MAVLink's microservices, each a small synchronous state machine: it takes
//! decoded messages (and the graph's state) and answers with messages to send and messages for
//! the graph. No sockets, no tokio: the shell in `hub.rs` does the I/O.

pub mod calibration;
pub mod command;
pub mod estimator_text;
pub mod events;
pub mod failure;
pub mod follow;
pub mod ftp;
pub mod heartbeat;
pub mod log_download;
pub mod mission;
pub mod offboard;
pub mod param_pack;
pub mod params;
pub mod sensor_health;
pub mod telemetry;
pub mod timesync;

use kestrel_proto::Time;
use kestrel_proto::messages::{
    CalibrationRequest, Command, FailureInjection, FencePlan, ManualControl, Mission, ParamSet, RallyPoints,
};
use mavlink::dialects::ardupilotmega::MavMessage;

/// The shape of a microservice that owns a protocol (as mini-redis's commands share one): it
/// keeps its own state, takes the messages of its protocol and the scheduler's ticks, and
/// answers both with the same [`Outputs`]. `Vehicle` offers each message to its services in
/// turn and handles what none of them speaks.
pub trait Service {
    /// `msg` from `from`, answered if it belongs to this service's protocol; `None` otherwise.
    fn on_message(&mut self, from: Sender, msg: &MavMessage, now: Time) -> Option<Outputs>;

    /// Periodic work at `now`: timeouts, retries, streams.
    fn on_tick(&mut self, now: Time) -> Outputs;
}

/// Who sent a message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sender {
    pub system_id: u32,
    pub component_id: u8,
}

impl Sender {
    /// The system id as a MAVLink `target_system` (ids above 255 cannot be addressed in a
    /// payload and become 0, broadcast).
    pub fn target_system(&self) -> u8 {
        u8::try_from(self.system_id).unwrap_or(0)
    }
}

/// What the link hands to the rest of the graph.
#[derive(Clone, Debug, PartialEq)]
pub enum ToGraph {
    /// A command nobody waits on (a heartbeat, an offboard target, MISSION_SET_CURRENT).
    Command(Command),
    /// A command whose `CommandResult` for `id` becomes its COMMAND_ACK.
    Request {
        id: u32,
        command: Command,
    },
    /// A calibration request whose answer for `id` becomes its COMMAND_ACK.
    Calibration {
        id: u32,
        request: CalibrationRequest,
    },
    /// A MAV_CMD_INJECT_FAILURE whose answer for its `id` becomes its COMMAND_ACK.
    InjectFailure(FailureInjection),
    Mission(Mission),
    /// An uploaded (or cleared) geofence, for the commander to enforce.
    Fence(FencePlan),
    /// The rally points uploaded (all of them) or cleared (none).
    Rally(RallyPoints),
    Manual(ManualControl),
    Param(ParamSet),
}

/// What a service wants done.
#[derive(Debug, Default)]
pub struct Outputs {
    /// Messages to send (routed by their target, broadcast when they have none).
    pub mav: Vec<MavMessage>,
    /// Messages to publish in the graph.
    pub graph: Vec<ToGraph>,
}

impl Outputs {
    /// Nothing to do.
    pub fn none() -> Outputs {
        Outputs::default()
    }

    /// One message to send.
    pub fn send(msg: MavMessage) -> Outputs {
        Outputs { mav: vec![msg], graph: Vec::new() }
    }

    /// Appends `other`.
    pub fn extend(&mut self, other: Outputs) {
        self.mav.extend(other.mav);
        self.graph.extend(other.graph);
    }
}
