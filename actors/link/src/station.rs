//! What the [`crate::hub::Hub`] serves: the MAVLink component this process is on its links.
//! The autopilot ([`crate::vehicle::Vehicle`]) and the companion computer
//! ([`crate::companion::Companion`]) share the links, the router and signing, and differ in
//! who they are, which frames would be a loop, and what they answer.

use kestrel_proto::Time;
use mavlink::dialects::ardupilotmega::MavMessage;

use crate::frame::Frame;
use crate::services::Sender;

/// Which endpoint of the config a link was opened by (its index in the endpoint list): a UDP
/// server's peers and a TCP server's connections share their endpoint's.
pub type EndpointIndex = usize;

/// What a station wants done after a frame or a tick.
#[derive(Debug)]
pub struct StationOut<G> {
    /// Messages to send under our identity (routed by their target, broadcast without one).
    pub mav: Vec<MavMessage>,
    /// Telemetry to send: a radio with a filling buffer may thin it.
    pub telemetry: Vec<MavMessage>,
    /// Messages for the graph.
    pub graph: Vec<G>,
}

impl<G> Default for StationOut<G> {
    fn default() -> Self {
        StationOut { mav: Vec::new(), telemetry: Vec::new(), graph: Vec::new() }
    }
}

/// A MAVLink component behind the hub. Synchronous and I/O-free, as the services are.
pub trait Station: Send + 'static {
    /// What it publishes into the graph.
    type Graph: Send + 'static;

    /// `(system id, component id)` our frames carry; `None` while it is not known yet (a
    /// companion before it heard its flight controller): nothing is sent then.
    fn identity(&self) -> Option<(u8, u8)>;

    /// Whether a frame claims to be ours: a loop or a forgery, dropped unrouted and unread.
    fn claims_ours(&self, frame: &Frame) -> bool;

    /// Whether a message addressed to `target` (system, component) is for this station alone,
    /// so the router must not forward it (a companion's system id is its flight controller's,
    /// which the router has heard on the flight controller's link).
    fn consumes(&self, _target_system: u8, _target_component: u8) -> bool {
        false
    }

    /// Whether `msg` is addressed to us (or broadcast): SETUP_SIGNING is answered only then.
    fn is_for_us(&self, msg: &MavMessage) -> bool;

    /// A frame from `sender` on a link of `endpoint`, after routing; `msg` is `None` when the
    /// payload would not decode.
    fn receive(
        &mut self,
        endpoint: EndpointIndex,
        sender: Sender,
        frame: &Frame,
        msg: Option<&MavMessage>,
        now: Time,
    ) -> StationOut<Self::Graph>;

    /// Our HEARTBEAT (1 Hz), if we send one now.
    fn heartbeat(&self) -> Option<MavMessage>;

    /// Periodic work (50 Hz): timeouts and what is due.
    fn on_tick(&mut self, now: Time) -> StationOut<Self::Graph>;

    /// Messages addressed to us that no service used.
    fn unhandled(&self) -> u64 {
        0
    }

    /// The parameter file's new text, once after each change, tagged for the writer's answer
    /// (`None`: unchanged or none kept).
    fn take_param_write(&mut self) -> Option<crate::services::params::ParamWrite> {
        None
    }

    /// The id the stored signing timestamp is kept under.
    fn signing_store_id(&self) -> u8;
}
