//! How Kestrel lays its messages into MCAP: the encodings it declares and the time unit
//! conversion, kept in one place so the writer and the reader cannot drift apart.

use kestrel_proto::Time;

/// Schema encoding of every Kestrel schema: a JSON Schema generated from the message type.
pub(crate) const SCHEMA_ENCODING: &str = "jsonschema";

/// Message encoding of every Kestrel channel: one JSON document per message.
pub(crate) const MESSAGE_ENCODING: &str = "json";

/// The MCAP header's `library`: names the writer, without anything that changes between runs.
pub(crate) const LIBRARY: &str = concat!("kestrel ", env!("CARGO_PKG_VERSION"));

/// MCAP times are nanoseconds; Kestrel's [`Time`] is microseconds. Saturates instead of
/// wrapping (only reachable 584 years after the clock's origin).
pub(crate) fn to_mcap_ns(time: Time) -> u64 {
    time.as_micros().saturating_mul(1_000)
}

/// The inverse of [`to_mcap_ns`]; sub-microsecond parts written by other tools are dropped.
pub(crate) fn from_mcap_ns(ns: u64) -> Time {
    Time::from_micros(ns / 1_000)
}
