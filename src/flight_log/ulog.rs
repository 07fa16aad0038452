//! Reading a PX4 ULog into columns (through the `px4-ulog` crate) and parameters.
//!
//! A log cut short or corrupted is read up to where it breaks (px4-ulog keeps the valid
//! prefix); [`Log::ended_early`] says so and where, from a walk over the messages' lengths
//! (ULog file format: a 16-byte header, then messages of a `u16` size, a `u8` type and the
//! payload).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use px4_ulog::full_parser::{Completeness, MultiId, SomeVec, read_file};
use px4_ulog::stream_parser::{
    Message, ParameterMessage, SimpleCallbackResult, read_file_with_simple_callback,
};

use super::FlightLogError;

/// The first instance of every topic of a log, as columns, and the log's parameters.
pub struct Log {
    path: PathBuf,
    topics: HashMap<String, HashMap<String, SomeVec>>,
    params: HashMap<String, f64>,
    ended_early: Option<UlogDamage>,
}

/// Where a ULog stops being readable.
#[derive(Clone, Debug, PartialEq)]
pub struct UlogDamage {
    /// End of the last whole message (byte offset): the file is intact up to here.
    pub intact_bytes: u64,
    /// The file's size (bytes).
    pub file_bytes: u64,
    /// What the parser found: the file ends inside a message, or a message does not parse.
    pub reason: String,
}

impl std::fmt::Display for UlogDamage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the ULog ends early ({}): whole messages end at byte {} of {} ({} bytes not read)",
            self.reason,
            self.intact_bytes,
            self.file_bytes,
            self.file_bytes.saturating_sub(self.intact_bytes)
        )
    }
}

/// `ULog` then 0x01 0x12 0x35: the first bytes of every ULog file.
pub const MAGIC: [u8; 7] = [b'U', b'L', b'o', b'g', 0x01, 0x12, 0x35];
/// The magic, a version byte and the start timestamp (µs).
const HEADER_BYTES: usize = 16;
/// A message's size (`u16`) and type (`u8`).
const MESSAGE_HEADER_BYTES: usize = 3;

impl Log {
    /// Reads the whole log at `path`, whose content is `bytes`.
    pub fn read(path: &Path, bytes: &[u8]) -> Result<Log, FlightLogError> {
        let name = path.to_str().ok_or_else(|| FlightLogError::Path { path: path.to_owned() })?;
        let io = |source| FlightLogError::Read { path: path.to_owned(), source };
        if bytes.len() < HEADER_BYTES || !bytes.starts_with(&MAGIC) {
            return Err(FlightLogError::NotALog { path: path.to_owned(), bytes: bytes.len() as u64 });
        }
        let parsed = contained(path, || read_file(name))?.map_err(io)?;
        let ended_early = match &parsed.completeness {
            Completeness::Complete => None,
            Completeness::Truncated => Some("it is cut short inside a message".to_owned()),
            Completeness::MalformedRecord(why) => Some(format!("a message does not parse: {why}")),
        }
        .map(|reason| UlogDamage {
            intact_bytes: whole_messages_end(bytes) as u64,
            file_bytes: bytes.len() as u64,
            reason,
        });
        let topics = parsed
            .messages
            .into_iter()
            .filter_map(|(topic, mut instances)| {
                instances.remove(&MultiId::new(0)).map(|fields| (topic, fields))
            })
            .collect();
        let mut params = HashMap::new();
        contained(path, || {
            read_file_with_simple_callback(name, &mut |msg| {
                if let Message::ParameterMessage(p) = msg {
                    match p {
                        ParameterMessage::Float(name, v, _) => {
                            params.insert((*name).to_owned(), f64::from(*v))
                        }
                        ParameterMessage::Int32(name, v, _) => {
                            params.insert((*name).to_owned(), f64::from(*v))
                        }
                    };
                }
                SimpleCallbackResult::KeepReading
            })
        })?
        .map_err(io)?;
        Ok(Log { path: path.to_owned(), topics, params, ended_early })
    }

    /// Where the log breaks, when it does before its end.
    pub fn ended_early(&self) -> Option<&UlogDamage> {
        self.ended_early.as_ref()
    }

    /// The log's topics (first instances), in name order.
    pub fn topic_names(&self) -> impl Iterator<Item = &str> {
        let mut names: Vec<&str> = self.topics.keys().map(String::as_str).collect();
        names.sort_unstable();
        names.into_iter()
    }

    /// Whether the log has `topic`.
    pub fn has(&self, topic: &str) -> bool {
        self.topics.contains_key(topic)
    }

    /// A parameter's value as the log started.
    pub fn param(&self, name: &str) -> Option<f64> {
        self.params.get(name).copied()
    }

    /// Whether `topic` has `field`.
    pub fn has_field(&self, topic: &str, field: &str) -> bool {
        self.topics.get(topic).is_some_and(|t| t.contains_key(field))
    }

    /// A numeric column.
    pub fn column(&self, topic: &str, field: &str) -> Result<Vec<f64>, FlightLogError> {
        let fields = self.topics.get(topic).ok_or_else(|| self.missing(topic, None))?;
        let values = fields.get(field).ok_or_else(|| self.missing(topic, Some(field)))?;
        Ok(to_f64(values))
    }

    /// The first of `fields` the topic has, with the index of the one found.
    pub fn column_any(&self, topic: &str, fields: &[&str]) -> Result<(usize, Vec<f64>), FlightLogError> {
        for (i, field) in fields.iter().enumerate() {
            if self.has_field(topic, field) {
                return Ok((i, self.column(topic, field)?));
            }
        }
        Err(self.missing(topic, fields.first().copied()))
    }

    /// Sample times of `topic` (µs since boot): `timestamp_sample` where logged, else `timestamp`.
    pub fn sample_times_us(&self, topic: &str) -> Result<Vec<u64>, FlightLogError> {
        let (_, t) = self.column_any(topic, &["timestamp_sample", "timestamp"])?;
        Ok(t.into_iter().map(|t| t.max(0.0) as u64).collect())
    }

    /// Publication times of `topic` (µs since boot).
    pub fn times_us(&self, topic: &str) -> Result<Vec<u64>, FlightLogError> {
        Ok(self.column(topic, "timestamp")?.into_iter().map(|t| t.max(0.0) as u64).collect())
    }

    /// Three columns `name[0..3]` as vectors.
    pub fn vec3(&self, topic: &str, name: &str) -> Result<Vec<[f64; 3]>, FlightLogError> {
        let c: Vec<Vec<f64>> =
            (0..3).map(|i| self.column(topic, &format!("{name}[{i}]"))).collect::<Result<_, _>>()?;
        Ok((0..c[0].len()).map(|k| [c[0][k], c[1][k], c[2][k]]).collect())
    }

    /// Four columns `name[0..4]`.
    pub fn vec4(&self, topic: &str, name: &str) -> Result<Vec<[f64; 4]>, FlightLogError> {
        let c: Vec<Vec<f64>> =
            (0..4).map(|i| self.column(topic, &format!("{name}[{i}]"))).collect::<Result<_, _>>()?;
        Ok((0..c[0].len()).map(|k| [c[0][k], c[1][k], c[2][k], c[3][k]]).collect())
    }

    fn missing(&self, topic: &str, field: Option<&str>) -> FlightLogError {
        FlightLogError::Missing {
            path: self.path.clone(),
            topic: topic.to_owned(),
            field: field.map(str::to_owned),
        }
    }
}

/// The end of the last whole message (byte offset), walking the messages' sizes from the
/// header.
/// Runs a px4-ulog parse, turning a panic inside it (some flipped bytes make it index past a
/// buffer) into [`FlightLogError::Unparsable`] naming the file.
fn contained<T>(path: &Path, parse: impl FnOnce() -> T) -> Result<T, FlightLogError> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(parse)).map_err(|payload| {
        let reason = payload
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| payload.downcast_ref::<&str>().map(|s| (*s).to_owned()))
            .unwrap_or_else(|| "the parser panicked".to_owned());
        FlightLogError::Unparsable { path: path.to_owned(), reason }
    })
}

fn whole_messages_end(bytes: &[u8]) -> usize {
    let mut at = HEADER_BYTES;
    while let Some(header) = bytes.get(at..at + MESSAGE_HEADER_BYTES) {
        let end = at + MESSAGE_HEADER_BYTES + usize::from(u16::from_le_bytes([header[0], header[1]]));
        if end > bytes.len() {
            break;
        }
        at = end;
    }
    at.min(bytes.len())
}

fn to_f64(values: &SomeVec) -> Vec<f64> {
    match values {
        SomeVec::Int8(v) => v.iter().map(|&x| f64::from(x)).collect(),
        SomeVec::UInt8(v) => v.iter().map(|&x| f64::from(x)).collect(),
        SomeVec::Int16(v) => v.iter().map(|&x| f64::from(x)).collect(),
        SomeVec::UInt16(v) => v.iter().map(|&x| f64::from(x)).collect(),
        SomeVec::Int32(v) => v.iter().map(|&x| f64::from(x)).collect(),
        SomeVec::UInt32(v) => v.iter().map(|&x| f64::from(x)).collect(),
        SomeVec::Int64(v) => v.iter().map(|&x| x as f64).collect(),
        SomeVec::UInt64(v) => v.iter().map(|&x| x as f64).collect(),
        SomeVec::Float(v) => v.iter().map(|&x| f64::from(x)).collect(),
        SomeVec::Double(v) => v.clone(),
        SomeVec::Bool(v) => v.iter().map(|&x| f64::from(u8::from(x))).collect(),
        SomeVec::Char(v) => v.iter().map(|&x| f64::from(u32::from(x))).collect(),
    }
}
