//! The companion link actor (config type `companion_link`): Kestrel as the companion computer of
//! a flight controller that flies (ArduPilot, PX4). Its graph side is small: obstacle sectors
//! in, the flight controller's state out; the MAVLink side is [`crate::companion::Companion`]
//! behind the same hub, router, signing and endpoint tasks as the autopilot's link.
//!
//! ```toml
//! [actors.fc_link]
//! type = "companion_link"
//! # The flight controller: a serial port on a Pixhawk's TELEM2, or ArduPilot SITL's TCP port.
//! params.flight_controller = { type = "serial", device = "/dev/ttyTHS1", baud = 921600 }
//! # Ground stations: they see the flight controller and the companion, as mavlink-router does.
//! params.ground_stations = [ { type = "udp_out", address = "127.0.0.1:14550" } ]
//! params.component_id = 196   # MAV_COMP_ID_OBSTACLE_AVOIDANCE (the default)
//! inputs.depth_grid = { topic = "depth_grid", mailbox = "latest" }
//! outputs.nav_state = "fc_nav_state"
//! outputs.vehicle_status = "fc_vehicle_status"
//! ```
//!
//! Graph ports: inputs `depth_grid` (DepthGrid: its sectors) and `proximity` (Proximity:
//! full-surround sectors with the obstacle memory), either or both, each sent as
//! OBSTACLE_DISTANCE; outputs `nav_state` (NavState) and `vehicle_status` (VehicleStatus) of the
//! flight controller; timers `heartbeat` (1 Hz) and `tick` (50 Hz).

use std::sync::{Arc, Mutex};
use std::time::Duration;

use kestrel_proto::messages::{DepthGrid, NavState, Proximity, VehicleStatus};
use kestrel_proto::{Actor, ActorError, Clock, Context, Publisher, Setup, Time};
use serde::Deserialize;

use crate::actor::TICK_PERIOD;
use crate::companion::{Companion, CompanionOut, DEFAULT_COMPONENT_ID, FC_ENDPOINT};
use crate::config::{EndpointConfig, EndpointKind};
use crate::hub::Hub;
use crate::transport::{GraphSink, OpenEndpoint, Shared, open_all};

/// `[actors.<name>.params]` of a `companion_link`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CompanionParams {
    /// The flight controller's endpoint (serial, or UDP/TCP to a simulator).
    pub flight_controller: EndpointConfig,
    /// Ground stations' endpoints; none is allowed (the companion alone on the flight
    /// controller's telemetry port).
    #[serde(default)]
    pub ground_stations: Vec<EndpointConfig>,
    /// Our MAVLink component id (1..=255): MAV_COMP_ID_OBSTACLE_AVOIDANCE (196) by default,
    /// MAV_COMP_ID_ONBOARD_COMPUTER (191) is the other usual one.
    #[serde(default = "default_component_id")]
    pub component_id: u8,
}

fn default_component_id() -> u8 {
    DEFAULT_COMPONENT_ID
}

/// Everything the companion link handles.
#[derive(Debug)]
pub enum CompanionInput {
    /// Obstacle sectors captured at the given time.
    Sectors(Time, Box<kestrel_proto::messages::ObstacleSectors>),
    Heartbeat(Time),
    Tick(Time),
}

#[derive(Clone)]
struct Outputs {
    nav: Publisher<NavState>,
    status: Publisher<VehicleStatus>,
}

impl Outputs {
    fn publish(&self, out: Vec<CompanionOut>) {
        for o in out {
            match o {
                CompanionOut::Nav(n) => self.nav.publish(*n),
                CompanionOut::Status(s) => self.status.publish(*s),
            }
        }
    }
}

/// The companion link actor.
pub struct CompanionActor {
    params: CompanionParams,
    config_dir: std::path::PathBuf,
    hub: Arc<Mutex<Hub<Companion>>>,
    outputs: Outputs,
    clock: Arc<dyn Clock>,
    endpoints: Vec<OpenEndpoint>,
}

impl CompanionActor {
    /// The endpoints opened by `start`: the flight controller's first.
    pub fn endpoints(&self) -> &[OpenEndpoint] {
        &self.endpoints
    }

    fn hub(&self) -> std::sync::MutexGuard<'_, Hub<Companion>> {
        self.hub.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The flight controller's endpoint, then the ground stations'.
    fn all_endpoints(&self) -> Vec<EndpointConfig> {
        std::iter::once(self.params.flight_controller.clone())
            .chain(self.params.ground_stations.clone())
            .collect()
    }
}

impl Actor for CompanionActor {
    type Params = CompanionParams;
    type Input = CompanionInput;

    fn build(params: &CompanionParams, setup: &mut impl Setup<CompanionInput>) -> Result<Self, ActorError> {
        if params.component_id == 0 {
            return Err(ActorError::Params("component_id must be 1..=255 (196: obstacle avoidance)".into()));
        }
        // A companion without its flight controller has nothing to do: a missing serial port is
        // refused at start, naming it (a radio to a ground station may come and go, a UART to
        // the flight controller does not).
        if let EndpointKind::Serial { device, .. } = &params.flight_controller.kind
            && !device.exists()
        {
            return Err(ActorError::Failed(format!(
                "flight controller serial port {} does not exist",
                device.display()
            )));
        }
        for endpoint in std::iter::once(&params.flight_controller).chain(&params.ground_stations) {
            if let EndpointKind::Serial { device, .. } = &endpoint.kind {
                setup.claim_device(device)?;
            }
        }
        setup.input("depth_grid", |g: DepthGrid| CompanionInput::Sectors(g.time, Box::new(g.sectors)));
        setup.input("proximity", |p: Proximity| CompanionInput::Sectors(p.time, Box::new(p.sectors)));
        setup.timer("heartbeat", Duration::from_secs(1), CompanionInput::Heartbeat);
        setup.timer("tick", TICK_PERIOD, CompanionInput::Tick);
        let outputs = Outputs { nav: setup.output("nav_state"), status: setup.output("vehicle_status") };
        Ok(CompanionActor {
            params: params.clone(),
            config_dir: setup.config_dir().to_owned(),
            hub: Arc::new(Mutex::new(Hub::new(Companion::new(params.component_id)))),
            outputs,
            clock: setup.clock(),
            endpoints: Vec::new(),
        })
    }

    async fn start(&mut self, ctx: &Context) -> Result<(), ActorError> {
        let outputs = self.outputs.clone();
        let graph: GraphSink<CompanionOut> = Arc::new(move |out| outputs.publish(out));
        let shared = Shared {
            hub: Arc::clone(&self.hub),
            clock: Arc::clone(&self.clock),
            shutdown: ctx.shutdown().clone(),
            graph,
            param_writer: None,
            endpoint: 0,
        };
        self.endpoints = open_all(&self.all_endpoints(), &self.config_dir, &shared)
            .await
            .map_err(|e| ActorError::Failed(e.to_string()))?;
        if !self.endpoints.iter().any(|e| e.endpoint == FC_ENDPOINT) {
            return Err(ActorError::Failed(format!(
                "the flight controller's endpoint {:?} did not open (the log says why)",
                self.params.flight_controller.kind
            )));
        }
        for e in &self.endpoints {
            tracing::info!(endpoint = %e.name, local = ?e.local_addr, "companion MAVLink endpoint open");
        }
        Ok(())
    }

    async fn handle(&mut self, _ctx: &Context, input: CompanionInput) -> Result<(), ActorError> {
        let out = {
            let mut hub = self.hub();
            match input {
                CompanionInput::Sectors(time, sectors) => {
                    hub.station().on_sectors(time, &sectors);
                    Vec::new()
                }
                CompanionInput::Heartbeat(_) => {
                    hub.send_heartbeat();
                    Vec::new()
                }
                CompanionInput::Tick(t) => hub.on_tick(t),
            }
        };
        self.outputs.publish(out);
        Ok(())
    }

    async fn stop(&mut self, _ctx: &Context) {
        let mut hub = self.hub();
        for (name, stats) in hub.link_stats() {
            tracing::info!(link = %name, ?stats, "companion MAVLink link counters");
        }
        let (stale, unsynced) = hub.station().obstacle_counters();
        tracing::info!(stats = ?hub.stats(), obstacle_stale = stale, obstacle_unsynced = unsynced, "companion MAVLink hub counters");
    }
}
