//! kestrel-link: MAVLink between the vehicle and ground stations (QGroundControl, Mission
//! Planner, MAVProxy, MAVSDK scripts) over UDP, TCP and serial radios.
//!
//! Layers, wire to graph:
//! * [`frame`] — MAVLink 1/2 framing: parse (resync, checksums, counters) and encode (signing).
//! * [`router`] — mavlink-router's rules between links, without sockets.
//! * [`services`] — the vehicle's microservices, each a pure state machine: heartbeat, commands,
//!   parameters, missions, telemetry, offboard control, status text.
//! * [`vehicle`] — dispatches what is addressed to us to the services.
//! * [`hub`] — links + router + vehicle: signatures, routing, per-link encoding, radio thinning.
//! * [`transport`] — UDP client/server, TCP server and serial tasks feeding the hub, and
//!   MAVLink 2 signing: one replay table for every link (`transport/signing.rs`), owner-only key
//!   files (`signing_key.rs`), the timestamp kept across restarts (`signing_store.rs`) and
//!   SETUP_SIGNING (`setup_signing.rs`).
//! * [`actor`] — [`LinkActor`], the graph's side.
//! * [`sim_gcs`] — [`SimGcsActor`], a ground station's heartbeats on the graph clock for
//!   simulated flights (silenced by the simulator's `link_lost` fault); no vehicle runs it.
//!
//! Custom modes follow ArduCopter's numbering ([`modes`]), so ground stations show our modes.
//!
//! Graph ports of [`LinkActor`]: inputs `nav_state` (NavState), `gps` (GpsFix), `battery`
//! (BatteryStatus), `vehicle_status` (VehicleStatus), `depth_grid` (DepthGrid), `rangefinder_up`
//! and `rangefinder_down` (RangefinderSample, sent as DISTANCE_SENSOR); outputs
//! `vehicle_command` (VehicleCommand, including `Command::Heartbeat` with the sender's system id
//! for every ground-station heartbeat), `mission` (Mission), `manual_control` (ManualControl,
//! `StickSource::Mavlink` with the sender's system id), `param_set` (ParamSet);
//! timers `heartbeat` (1 Hz) and `tick` (50 Hz, telemetry and timeouts).

pub mod actor;
pub mod companion;
pub mod companion_actor;
pub mod config;
pub mod frame;
pub mod hub;
pub mod modes;
pub mod router;
pub mod services;
pub mod sim_gcs;
pub mod station;
pub mod transport;
pub mod vehicle;

pub use actor::{LinkActor, LinkInput};
pub use companion_actor::{CompanionActor, CompanionParams};
pub use config::{EndpointConfig, EndpointKind, LinkParams, ParamKind, ParamSpec};
pub use sim_gcs::SimGcsActor;
