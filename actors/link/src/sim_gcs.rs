//! `SimGcsActor`: a ground station on the graph clock, for simulated flights. It sends a GCS
//! HEARTBEAT (`MAV_TYPE_GCS`, as QGroundControl and MAVProxy do at 1 Hz) over UDP to the
//! vehicle's link at `rate_hz`, and goes silent while the simulator's `link_lost` fault is
//! active (port `sim_fault`): the radio link is down, the vehicle stops hearing its ground
//! station.
//!
//! Why in the graph: a ground station outside it runs on the wall clock, and a lockstep flight
//! runs many times faster, so its heartbeats would be seconds of simulated time apart. Here each
//! heartbeat leaves at a simulated instant and takes the vehicle's whole path — the link's
//! socket and frame parser, `Command::Heartbeat`, the commander's data-link timer — so the
//! link-loss failsafe (`failsafe.link_timeout_s`, `link_action`) is tested as it flies.
//!
//! Ports — input `sim_fault` (SimFault); timer `heartbeat` at `rate_hz`.
//!
//! ```toml
//! [actors.gcs]
//! type = "sim_gcs"
//! params.address = "127.0.0.1:14560"   # the vehicle link's `udp_in` endpoint
//! inputs.sim_fault = { topic = "sim_fault", mailbox = "queue(16)" }
//! ```

use std::collections::BTreeSet;
use std::net::{Ipv4Addr, SocketAddr};

use kestrel_proto::messages::{SimFault, SimFaultPhase};
use kestrel_proto::{Actor, ActorError, Context, Setup, Time};
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega::{
    HEARTBEAT_DATA, MavAutopilot, MavMessage, MavModeFlag, MavState, MavType,
};
use serde::Deserialize;
use tokio::net::UdpSocket;

use crate::frame::encode;

/// The world file's fault kind that silences this ground station.
pub const LINK_LOST: &str = "link_lost";
/// QGroundControl's and Mission Planner's component id (`MAV_COMP_ID_MISSIONPLANNER`).
const GCS_COMPONENT_ID: u8 = 190;

/// `[actors.NAME.params]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimGcsParams {
    /// Where the vehicle's link listens (its `udp_in` endpoint).
    pub address: SocketAddr,
    /// Our system id; 255, as QGroundControl's and MAVProxy's.
    #[serde(default = "default_system_id")]
    pub system_id: u8,
    /// Heartbeats per second (Hz); ground stations send 1.
    #[serde(default = "default_rate_hz")]
    pub rate_hz: f64,
}

fn default_system_id() -> u8 {
    255
}

fn default_rate_hz() -> f64 {
    1.0
}

/// What the ground station handles.
#[derive(Debug)]
pub enum SimGcsInput {
    Fault(SimFault),
    Heartbeat(Time),
}

/// Whether the link is down: the `link_lost` entries of the world file now active, by index.
#[derive(Debug, Default)]
pub struct LinkState {
    lost: BTreeSet<u32>,
}

impl LinkState {
    /// Takes a fault's start or end; other kinds leave the link up.
    pub fn on_fault(&mut self, fault: &SimFault) {
        if fault.kind != LINK_LOST {
            return;
        }
        match fault.phase {
            SimFaultPhase::Started => self.lost.insert(fault.index),
            SimFaultPhase::Ended => self.lost.remove(&fault.index),
        };
    }

    /// Whether a heartbeat reaches the vehicle now.
    pub fn up(&self) -> bool {
        self.lost.is_empty()
    }
}

/// The ground station's HEARTBEAT.
pub fn gcs_heartbeat() -> MavMessage {
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: MavType::MAV_TYPE_GCS,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        base_mode: MavModeFlag::empty(),
        system_status: MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
    })
}

/// The simulated ground station (config type name: `sim_gcs`).
pub struct SimGcsActor {
    params: SimGcsParams,
    socket: Option<UdpSocket>,
    link: LinkState,
    sequence: u8,
    /// Heartbeats sent, and those the socket refused (each refusal is logged).
    sent: u64,
    refused: u64,
}

impl Actor for SimGcsActor {
    type Params = SimGcsParams;
    type Input = SimGcsInput;

    fn build(params: &SimGcsParams, setup: &mut impl Setup<SimGcsInput>) -> Result<Self, ActorError> {
        let period = kestrel_proto::timing::period_of_rate("rate_hz", params.rate_hz, 0.1, 50.0)?;
        setup.input("sim_fault", SimGcsInput::Fault);
        setup.timer("heartbeat", period, SimGcsInput::Heartbeat);
        Ok(SimGcsActor {
            params: params.clone(),
            socket: None,
            link: LinkState::default(),
            sequence: 0,
            sent: 0,
            refused: 0,
        })
    }

    async fn start(&mut self, _ctx: &Context) -> Result<(), ActorError> {
        let ip =
            if self.params.address.ip().is_loopback() { Ipv4Addr::LOCALHOST } else { Ipv4Addr::UNSPECIFIED };
        let socket = UdpSocket::bind((ip, 0)).await.map_err(|source| ActorError::Io {
            what: "the simulated ground station's UDP socket".into(),
            source,
        })?;
        self.socket = Some(socket);
        Ok(())
    }

    async fn handle(&mut self, _ctx: &Context, input: SimGcsInput) -> Result<(), ActorError> {
        match input {
            SimGcsInput::Fault(f) => {
                let was_up = self.link.up();
                self.link.on_fault(&f);
                if was_up != self.link.up() {
                    tracing::info!(
                        up = self.link.up(),
                        t_s = f.time.as_secs_f64(),
                        "simulated ground station link"
                    );
                }
            }
            SimGcsInput::Heartbeat(_) if self.link.up() => {
                let Some(socket) = &self.socket else { return Ok(()) };
                let header = MavHeader {
                    system_id: u32::from(self.params.system_id),
                    component_id: GCS_COMPONENT_ID,
                    sequence: self.sequence,
                };
                self.sequence = self.sequence.wrapping_add(1);
                match socket.send_to(&encode(header, &gcs_heartbeat(), None), self.params.address).await {
                    Ok(_) => self.sent += 1,
                    Err(e) => {
                        self.refused += 1;
                        tracing::warn!(address = %self.params.address, error = %e, "ground station heartbeat not sent");
                    }
                }
            }
            SimGcsInput::Heartbeat(_) => {}
        }
        Ok(())
    }

    async fn stop(&mut self, _ctx: &Context) {
        tracing::info!(sent = self.sent, refused = self.refused, "simulated ground station heartbeats");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fault(kind: &str, index: u32, phase: SimFaultPhase) -> SimFault {
        SimFault {
            time: Time::ZERO,
            index,
            phase,
            kind: kind.into(),
            values: String::new(),
            at_s: 0.0,
            for_s: None,
        }
    }

    #[test]
    fn the_link_is_down_while_any_link_lost_entry_is_active_and_only_then() {
        let mut link = LinkState::default();
        link.on_fault(&fault("gps_off", 0, SimFaultPhase::Started));
        assert!(link.up(), "other kinds leave the link up");
        link.on_fault(&fault(LINK_LOST, 1, SimFaultPhase::Started));
        link.on_fault(&fault(LINK_LOST, 2, SimFaultPhase::Started));
        assert!(!link.up());
        link.on_fault(&fault(LINK_LOST, 1, SimFaultPhase::Ended));
        assert!(!link.up(), "entry 2 is still active");
        link.on_fault(&fault(LINK_LOST, 2, SimFaultPhase::Ended));
        assert!(link.up());
    }

    #[test]
    fn the_heartbeat_is_a_whole_ground_station_frame() {
        let header = MavHeader { system_id: 255, component_id: GCS_COMPONENT_ID, sequence: 7 };
        let mut frames = Vec::new();
        crate::frame::FrameParser::new().push(&encode(header, &gcs_heartbeat(), None), &mut frames);
        assert_eq!(frames.len(), 1, "one whole frame");
        let Ok(MavMessage::HEARTBEAT(hb)) = frames[0].decode() else {
            panic!("a heartbeat: {:?}", frames[0].decode())
        };
        assert_eq!((hb.mavtype, hb.autopilot), (MavType::MAV_TYPE_GCS, MavAutopilot::MAV_AUTOPILOT_INVALID));
    }
}
