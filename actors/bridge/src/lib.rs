//! Kestrel's Zenoh bridge: one graph across machines (the thesis's split of flight control and
//! vision onto two computers, a fleet seen from one ground station).
//!
//! * [`key_expr`]: `kestrel/<vehicle>/<topic>`, checked so a name never becomes a wildcard.
//! * [`catalogue`]: the topics the bridge carries, each with its one message type.
//! * [`payload`]: the recorder's JSON with its schema name, the capture time as the sample's
//!   timestamp, and the mapping of times between two processes' graph clocks.
//! * [`params`]: the actor's parameters, checked with errors that name the parameter.
//! * [`rate_limit`]: a topic's `max_rate_hz`, for links that carry less than loopback.
//! * [`zenoh_file`]: the Zenoh config file: authentication and access control, Zenoh's own.
//! * [`sources`]: the Zenoh ids that may send the topics that move the motors, checked on
//!   every sample behind Zenoh's access control.
//! * [`BridgeActor`]: the actor shell around a Zenoh session.

mod actor;
pub mod catalogue;
pub mod error;
pub mod hop_latency;
pub mod key_expr;
pub mod params;
pub mod payload;
pub mod rate_limit;
pub mod sources;
pub mod zenoh_file;

pub use actor::{BridgeActor, BridgeInput};
pub use error::BridgeError;
pub use params::{BridgeParams, Mode};
