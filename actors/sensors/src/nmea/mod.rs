//! NMEA 0183 fallback for receivers that do not speak UBX: [`sentence`] splits a byte stream
//! into checksum-valid sentences, [`messages`] decodes GGA, RMC and VTG, and [`fix`] joins
//! one epoch's position and velocity into a [`GpsFix`](kestrel_proto::messages::GpsFix).

pub mod fix;
pub mod messages;
pub mod sentence;

pub use fix::{NmeaFixAssembler, NmeaFixOptions};
pub use messages::{Gga, NmeaMessage, Rmc, Vtg};
pub use sentence::{NmeaError, NmeaReader, Sentence};
