//! A bridged message on the wire, readable by any Zenoh client:
//! * payload: the message as the flight-log recorder stores it, one JSON document;
//! * encoding: `application/json` with the message's schema name (`kestrel.NavState`), the
//!   name of the JSON Schema the recorder writes into every log;
//! * timestamp: when the content was captured, on the UNIX wall clock (the sample's own Zenoh
//!   timestamp, so tools that know nothing of Kestrel sort and age samples right);
//! * attachment: when the bridge sent it, UNIX time in µs as 8 little-endian bytes, from which
//!   the receiving bridge measures its hop's latency.
//!
//! Graph clocks count from their own process's start, so the receiver moves every time in the
//! message by the difference of the two clocks' origins on the wall clock, read from the
//! capture timestamp. Both machines' wall clocks must agree (NTP, PTP; on one machine they
//! do); a sample without a timestamp (from a client that sets none) is taken as captured on
//! arrival. No time from the network is ever after the receiver's clock: a capture time in the
//! future (a fast clock, or a sender that wants its message to outlive every timeout) is
//! clamped to the arrival, and counted.

use kestrel_proto::Time;

use crate::catalogue::Bridged;
use crate::error::BridgeError;

/// The Zenoh encoding of every bridged payload, before its schema name.
pub const MEDIA_TYPE: &str = "application/json";

/// The wall-clock time (UNIX µs) at which a graph clock read zero: converts that clock's
/// times to and from the wall clock.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ClockOrigin {
    unix_us: i64,
}

impl ClockOrigin {
    /// The origin of a clock that reads `graph_now` while the wall clock reads `unix_now_us`.
    pub fn at(graph_now: Time, unix_now_us: i64) -> ClockOrigin {
        ClockOrigin { unix_us: unix_now_us.saturating_sub(micros_i64(graph_now)) }
    }

    /// `time` on this clock as UNIX µs.
    pub fn to_unix_us(self, time: Time) -> i64 {
        self.unix_us.saturating_add(micros_i64(time))
    }

    /// By how much a time on a clock whose origin is `self` moves to become a time on `local`.
    pub fn shift_onto_us(self, local: ClockOrigin) -> i64 {
        self.unix_us.saturating_sub(local.unix_us)
    }
}

fn micros_i64(time: Time) -> i64 {
    i64::try_from(time.as_micros()).unwrap_or(i64::MAX)
}

/// A message ready to send.
#[derive(Clone, Debug, PartialEq)]
pub struct Outgoing {
    /// Its topic (the last chunk of its key expression).
    pub topic: &'static str,
    /// The message's schema name.
    pub schema: &'static str,
    /// The recorder's JSON of the message.
    pub json: Vec<u8>,
    /// Capture time on the sender's graph clock.
    pub captured: Time,
    /// The same on the UNIX wall clock (µs), set by the sending bridge, which reads that clock.
    pub captured_unix_us: i64,
}

/// Serialises `msg` as the recorder does; `Err` for a message JSON cannot hold.
pub fn encode<T: Bridged>(msg: &T) -> Result<Outgoing, String> {
    let json = serde_json::to_vec(msg).map_err(|e| format!("{} not serialisable: {e}", T::TYPE_NAME))?;
    Ok(Outgoing { topic: T::TOPIC, schema: T::TYPE_NAME, json, captured: msg.time(), captured_unix_us: 0 })
}

/// The encoding string of a payload of schema `schema`, as Zenoh prints it.
pub fn encoding_name(schema: &str) -> String {
    format!("{MEDIA_TYPE};{schema}")
}

/// The send-time attachment.
pub fn sent_attachment(unix_us: i64) -> [u8; 8] {
    unix_us.to_le_bytes()
}

/// The send time of an attachment made by [`sent_attachment`]; `None` for any other.
pub fn read_sent_attachment(bytes: &[u8]) -> Option<i64> {
    bytes.try_into().ok().map(i64::from_le_bytes)
}

/// A received sample, as Zenoh handed it over.
#[derive(Clone, Copy, Debug)]
pub struct Received<'a> {
    pub key: &'a str,
    /// The sample's encoding as Zenoh prints it (`application/json;kestrel.NavState`).
    pub encoding: &'a str,
    pub payload: &'a [u8],
    /// The sample's timestamp as UNIX µs, if it has one.
    pub captured_unix_us: Option<i64>,
}

/// A message taken from the network.
#[derive(Clone, Debug, PartialEq)]
pub struct Decoded<T> {
    pub msg: T,
    /// By how much (µs) its furthest time was after the receiver's clock before it was clamped
    /// to it; 0 when none was.
    pub clamped_by_us: u64,
}

/// The message of `sample`, with its times on the local clock (`local`, which reads `now`) and
/// none after `now` (a future capture time is clamped to `now`, and by how much is returned),
/// checked; `Err` names the key, the schema and what was wrong.
pub fn decode<T: Bridged>(
    sample: Received<'_>,
    local: ClockOrigin,
    now: Time,
) -> Result<Decoded<T>, BridgeError> {
    let error = |why: String| BridgeError::Payload { key: sample.key.to_owned(), schema: T::TYPE_NAME, why };
    let (media, schema) = sample.encoding.split_once(';').unwrap_or((sample.encoding, ""));
    if media != MEDIA_TYPE {
        return Err(error(format!("encoding '{}' is not {MEDIA_TYPE}", sample.encoding)));
    }
    if !schema.is_empty() && schema != T::TYPE_NAME {
        return Err(error(format!("schema '{schema}' is not this topic's")));
    }
    let mut msg: T = serde_json::from_slice(sample.payload).map_err(|e| error(e.to_string()))?;
    let by_us = match sample.captured_unix_us {
        Some(unix_us) => ClockOrigin::at(msg.time(), unix_us).shift_onto_us(local),
        None => micros_i64(now).saturating_sub(micros_i64(msg.time())),
    };
    msg.shift_times(by_us);
    let clamped_by_us = msg.clamp_times(now);
    msg.check().map_err(error)?;
    Ok(Decoded { msg, clamped_by_us })
}

#[cfg(test)]
mod tests;
