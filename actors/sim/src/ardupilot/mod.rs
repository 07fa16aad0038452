//! ArduPilot SITL flying on this simulator's physics, through ArduPilot's JSON physics
//! protocol (`--model JSON`): [`packet`] reads SITL's servo packets, [`backend`] steps the
//! simulator one frame per packet and writes the state SITL wants back, [`server`] is the UDP
//! shell, and [`config`] is `config/ardupilot/sitl.toml`. `kestrel sitl ardupilot` starts SITL
//! and the server together.

pub mod backend;
pub mod config;
pub mod packet;
pub mod server;

pub use backend::{JsonBackend, Summary, TraceSample};
pub use config::SitlConfig;
pub use packet::{PacketError, ServoPacket};
pub use server::JsonServer;
