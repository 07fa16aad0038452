//! Kestrel's built-in multirotor simulator.
//!
//! A pure, synchronous, deterministic core ([`Simulator`]) integrates a 6-DOF rigid body driven
//! by first-order-lag motors, wind, drag and ground contact, checks collisions against the
//! world's obstacles and produces the sensor streams a real airframe would (IMU, GPS,
//! barometer, magnetometer, rangefinders, battery) plus ground truth, each stamped with its
//! *measurement* time and released after its configured lag. [`SimActor`] is the thin actor
//! shell that feeds it actuator outputs and publishes what it releases. [`camera`] renders a stereo pair from
//! the true pose by ray casting, and [`CameraSimActor`] publishes it as `stereo_frame`.
//!
//! Frames follow `kestrel-proto`: NED earth frame around home, FRD body frame, quaternions
//! rotating FRD into NED. Configuration comes from two TOML files (a vehicle and a world); every
//! field has a default in code and is checked before use, so a bad file is a typed error naming
//! the file and field, never a panic.

mod actor;
pub mod ardupilot;
mod battery;
pub mod camera;
mod camera_actor;
mod config_file;
mod drag;
mod error;
pub mod faults;
pub mod forest;
mod ground;
pub mod handling;
pub mod hil;
pub mod live_faults;
mod motors;
mod obstacles;
mod rigid_body;
pub mod sensors;
mod simulator;
mod vehicle;
mod wind;
mod world;

pub use actor::{SimActor, SimActorParams, SimInput};
pub use battery::BatteryParams;
pub use camera_actor::{CameraInput, CameraSimActor, CameraSimParams};
pub use drag::DragParams;
pub use error::{ConfigError, InvalidParam};
pub use faults::{Fault, FaultEffects, FaultKind, FaultSchedule};

pub use ground::ContactParams;
pub use motors::MotorParams;
pub use obstacles::{Obstacle, ObstacleGeometry};
pub use rigid_body::{RigidBody, RigidBodyState, Wrench};
pub use simulator::{InitialState, RawSample, SimOptions, SimOutput, Simulator};
pub use vehicle::{VehicleParams, hover_throttle};
pub use wind::WindParams;
pub use world::{Home, MagneticField, World};
