//! The messages of the graph, one file per sensor or subsystem.

mod actuators;
mod baro;
mod battery;
mod gps;
mod ground_truth;
mod imu;
mod mag;
mod nav_state;
mod supervisor;

pub use actuators::{ActuatorOutputs, MAX_MOTORS};
pub use baro::BaroSample;
pub use battery::BatteryStatus;
pub use gps::{GpsFix, GpsFixType};
pub use ground_truth::GroundTruth;
pub use imu::ImuSample;
pub use mag::MagSample;
pub use nav_state::{NavState, NavValidity};
pub use supervisor::{SupervisorEvent, SupervisorEventKind};
