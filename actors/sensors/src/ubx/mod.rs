//! u-blox UBX protocol (u-blox 8 / M8 Receiver Description incl. Protocol Specification,
//! UBX-13003221, §32 "UBX Protocol"): [`frame`] encodes frames and computes their checksum,
//! [`parser`] finds frames in a byte stream and resynchronises after garbage, [`nav_pvt`]
//! decodes NAV-PVT into a [`GpsFix`](kestrel_proto::messages::GpsFix), [`config`] builds the
//! configuration messages the driver sends at start-up, and [`validity_clock`] maps the
//! receiver's time of week onto the graph clock.

pub mod config;
pub mod frame;
pub mod nav_pvt;
pub mod parser;
pub mod validity_clock;

pub use config::{DynamicModel, cfg_msg, cfg_nav5, cfg_prt_uart, cfg_rate};
pub use frame::{UbxFrame, checksum, encode};
pub use nav_pvt::{NavPvt, NavPvtError};
pub use parser::{ParserStats, UbxParser};
pub use validity_clock::ValidityClock;
