//! Futaba SBUS, the serial RC protocol of most receivers (100 000 baud, 8E2, inverted line):
//! [`frame`] decodes the 25-byte frame and finds frames in a byte stream, [`sticks`] maps
//! channels onto [`ManualControl`](kestrel_proto::messages::ManualControl).

pub mod frame;
pub mod sticks;

pub use frame::{SbusError, SbusFrame, SbusParser};
pub use sticks::{ChannelRange, StickMap};
