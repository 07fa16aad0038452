//! The reading side: [`LogReader`] opens a flight log and reads topics back, typed or raw.
//!
//! The whole file is read into memory and scanned once at open, so [`LogReader::topics`] is
//! exact even for MCAP files written without a summary section by other tools.
//!
//! A log cut short (the recorder killed, the disk full) or damaged is read as far as it is
//! readable, as a stream reader does: every message before the first unreadable record, with a
//! [`LogDamage`] saying how much that is and where the file stops making sense. Only a file
//! that is not an MCAP at all (no magic) is refused.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use kestrel_proto::{Message, Time};
use mcap::MessageStream;

use super::error::RecorderError;
use super::format::{MESSAGE_ENCODING, from_mcap_ns};

/// A flight log opened for reading.
pub struct LogReader {
    path: PathBuf,
    /// The file's bytes; messages are decompressed from them on each read.
    bytes: Vec<u8>,
    /// Channels that carry messages, by MCAP channel id.
    channels: BTreeMap<u16, ChannelInfo>,
    /// Where the file stops being readable, if it does before its end.
    damage: Option<LogDamage>,
}

/// How much of a damaged or truncated log could be read.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LogDamage {
    /// Messages read, all of them before the damage.
    pub messages_read: u64,
    /// Messages the file's summary says it holds, when the summary survived.
    pub messages_expected: Option<u64>,
    /// Log time of the last message read (s), if any was.
    pub last_log_time_s: Option<f64>,
    /// End of the last whole record (byte offset): the file is intact up to here.
    pub intact_bytes: u64,
    /// The file's size (bytes).
    pub file_bytes: u64,
    /// What the MCAP reader found there.
    pub reason: String,
}

impl fmt::Display for LogDamage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "read {} messages", self.messages_read)?;
        if let Some(expected) = self.messages_expected {
            write!(f, " of {expected} ({} lost)", expected.saturating_sub(self.messages_read))?;
        }
        if let Some(t) = self.last_log_time_s {
            write!(f, ", up to log time {t:.3} s")?;
        }
        if self.intact_bytes < self.file_bytes {
            write!(
                f,
                "; whole records end at byte {} of {} ({} bytes cut short or unreadable)",
                self.intact_bytes,
                self.file_bytes,
                self.file_bytes - self.intact_bytes
            )?;
        } else {
            write!(f, "; all {} bytes are whole records, one of them unreadable", self.file_bytes)?;
        }
        write!(f, ": {}", self.reason)
    }
}

/// A topic in a log.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TopicInfo {
    /// Topic name.
    pub topic: String,
    /// Schema name, e.g. `kestrel.ImuSample` (empty if the channel has no schema).
    pub schema_name: String,
    /// Schema encoding (`jsonschema` for Kestrel logs).
    pub schema_encoding: String,
    /// Message encoding (`json` for Kestrel logs).
    pub message_encoding: String,
    /// Messages on the topic.
    pub message_count: u64,
}

/// A message read back with its log metadata.
#[derive(Clone, Debug, PartialEq)]
pub struct Recorded<T> {
    /// When the runtime received and recorded the message (graph clock).
    pub log_time: Time,
    /// When the content was measured or produced (the message's own `time()`).
    pub publish_time: Time,
    /// Position of the message on its topic, counting from 0.
    pub sequence: u32,
    pub message: T,
}

/// A message of any type, as stored: for tools that print or convert logs without knowing the
/// Rust types.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RawRecord {
    pub topic: Arc<str>,
    /// Schema name, e.g. `kestrel.GpsFix`.
    pub schema_name: Arc<str>,
    /// When the runtime recorded the message (graph clock).
    pub log_time: Time,
    /// When the content was measured or produced.
    pub publish_time: Time,
    /// Position of the message on its topic, counting from 0.
    pub sequence: u32,
    /// The message bytes: one JSON document for Kestrel logs (see [`TopicInfo`] for others).
    pub data: Vec<u8>,
}

/// What the reader keeps per channel.
struct ChannelInfo {
    topic: Arc<str>,
    schema_name: Arc<str>,
    schema_encoding: String,
    message_encoding: String,
    message_count: u64,
}

impl LogReader {
    /// Reads the MCAP file at `path` and indexes its topics.
    pub fn open(path: &Path) -> Result<LogReader, RecorderError> {
        let bytes =
            std::fs::read(path).map_err(|source| RecorderError::Open { path: path.to_path_buf(), source })?;
        LogReader::from_bytes(path, bytes)
    }

    /// [`LogReader::open`] for a file already in memory (`path` names it in messages).
    pub fn from_bytes(path: &Path, bytes: Vec<u8>) -> Result<LogReader, RecorderError> {
        let mut reader =
            LogReader { path: path.to_path_buf(), bytes, channels: BTreeMap::new(), damage: None };
        if !reader.bytes.starts_with(mcap::MAGIC) {
            return Err(RecorderError::NotMcap {
                path: path.to_path_buf(),
                bytes: reader.bytes.len() as u64,
            });
        }
        // The `mcap` reader sizes buffers from the lengths inside a chunk before it can check
        // them, so a damaged chunk could make it allocate exabytes and abort: the stream gets
        // only the records before the first chunk that does not hold together.
        let sound = sound_prefix(&reader.bytes);
        let mut channels = BTreeMap::new();
        let (mut read, mut last_log_time, mut damage) = (0u64, None, None);
        for message in reader.messages_in(sound) {
            let message = match message {
                Ok(m) => m,
                Err(e) => {
                    damage = Some(LogDamage {
                        messages_read: read,
                        messages_expected: expected_messages(&reader.bytes),
                        last_log_time_s: last_log_time.map(|t: Time| t.as_secs_f64()),
                        intact_bytes: whole_records_end(&reader.bytes[..sound]) as u64,
                        file_bytes: reader.bytes.len() as u64,
                        reason: if sound < whole_records_end(&reader.bytes) {
                            format!(
                                "the chunk at byte {sound} is damaged (its data is not its stated size and CRC)"
                            )
                        } else {
                            e.to_string()
                        },
                    });
                    break;
                }
            };
            read += 1;
            last_log_time = Some(from_mcap_ns(message.log_time));
            let channel = &message.channel;
            channels
                .entry(channel.id)
                .or_insert_with(|| {
                    let schema = channel.schema.as_deref();
                    ChannelInfo {
                        topic: channel.topic.as_str().into(),
                        schema_name: schema.map_or("", |s| s.name.as_str()).into(),
                        schema_encoding: schema.map_or("", |s| s.encoding.as_str()).to_owned(),
                        message_encoding: channel.message_encoding.clone(),
                        message_count: 0,
                    }
                })
                .message_count += 1;
        }
        reader.channels = channels;
        reader.damage = damage;
        Ok(reader)
    }

    /// The file being read.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// How much was lost, when the file is truncated or damaged; every read stops where the
    /// damage begins.
    pub fn damage(&self) -> Option<&LogDamage> {
        self.damage.as_ref()
    }

    /// The topics that hold messages, sorted by name.
    pub fn topics(&self) -> Vec<TopicInfo> {
        let mut topics: Vec<TopicInfo> = self
            .channels
            .values()
            .map(|c| TopicInfo {
                topic: c.topic.to_string(),
                schema_name: c.schema_name.to_string(),
                schema_encoding: c.schema_encoding.clone(),
                message_encoding: c.message_encoding.clone(),
                message_count: c.message_count,
            })
            .collect();
        topics.sort_by(|a, b| a.topic.cmp(&b.topic));
        topics
    }

    /// Every message on `topic`, decoded as `T`, in file order.
    ///
    /// Fails, naming the topic, if the log has no such topic, if the topic holds another type
    /// (its schema name is not `T::TYPE_NAME`), or if a message does not decode.
    pub fn read<T: Message>(&self, topic: &str) -> Result<Vec<Recorded<T>>, RecorderError> {
        let wanted = self.channels_of::<T>(topic)?;
        let mut out = Vec::new();
        for message in self.messages() {
            let message = message?;
            if !wanted.contains(&message.channel.id) {
                continue;
            }
            let decoded = serde_json::from_slice(&message.data).map_err(|source| RecorderError::Decode {
                path: self.path.clone(),
                topic: topic.to_owned(),
                type_name: T::TYPE_NAME.to_owned(),
                sequence: message.sequence,
                source,
            })?;
            out.push(Recorded {
                log_time: from_mcap_ns(message.log_time),
                publish_time: from_mcap_ns(message.publish_time),
                sequence: message.sequence,
                message: decoded,
            });
        }
        Ok(out)
    }

    /// Every message in file order, undecoded.
    pub fn raw(&self) -> impl Iterator<Item = Result<RawRecord, RecorderError>> + '_ {
        self.messages().map(|message| {
            let message = message?;
            let info = self.channels.get(&message.channel.id);
            Ok(RawRecord {
                topic: info.map_or_else(|| message.channel.topic.as_str().into(), |c| Arc::clone(&c.topic)),
                schema_name: info.map_or_else(|| "".into(), |c| Arc::clone(&c.schema_name)),
                log_time: from_mcap_ns(message.log_time),
                publish_time: from_mcap_ns(message.publish_time),
                sequence: message.sequence,
                data: message.data.into_owned(),
            })
        })
    }

    /// The ids of the channels named `topic`, after checking they hold JSON-encoded `T`.
    fn channels_of<T: Message>(&self, topic: &str) -> Result<BTreeSet<u16>, RecorderError> {
        let mut ids = BTreeSet::new();
        for (id, channel) in &self.channels {
            if &*channel.topic != topic {
                continue;
            }
            if &*channel.schema_name != T::TYPE_NAME {
                return Err(RecorderError::TypeMismatch {
                    path: self.path.clone(),
                    topic: topic.to_owned(),
                    expected: T::TYPE_NAME.to_owned(),
                    found: channel.schema_name.to_string(),
                });
            }
            if channel.message_encoding != MESSAGE_ENCODING {
                return Err(RecorderError::UnsupportedEncoding {
                    path: self.path.clone(),
                    topic: topic.to_owned(),
                    encoding: channel.message_encoding.clone(),
                });
            }
            ids.insert(*id);
        }
        if ids.is_empty() {
            return Err(RecorderError::UnknownTopic {
                path: self.path.clone(),
                topic: topic.to_owned(),
                available: self.topics().into_iter().map(|t| t.topic).collect(),
            });
        }
        Ok(ids)
    }

    /// The file's messages in order, decompressing chunks as it goes; in a damaged file, only
    /// those before the damage (the stream is deterministic, so the same ones each time).
    fn messages(&self) -> impl Iterator<Item = Result<mcap::Message<'static>, RecorderError>> + '_ {
        let end = if self.damage.is_some() { sound_prefix(&self.bytes) } else { self.bytes.len() };
        self.messages_in(end)
    }

    /// The messages of the file's first `end` bytes.
    fn messages_in(
        &self,
        end: usize,
    ) -> impl Iterator<Item = Result<mcap::Message<'static>, RecorderError>> + '_ {
        let corrupt = |source| RecorderError::Corrupt { path: self.path.clone(), source };
        let (stream, error) = match MessageStream::new(&self.bytes[..end]) {
            Ok(stream) => (Some(stream), None),
            Err(e) => (None, Some(corrupt(e))),
        };
        let readable = self
            .damage
            .as_ref()
            .map_or(usize::MAX, |d| usize::try_from(d.messages_read).unwrap_or(usize::MAX));
        error
            .map(Err)
            .into_iter()
            .chain(stream.into_iter().flatten().map(move |m| m.map_err(corrupt)))
            .take(readable)
    }
}

/// Size of an MCAP record's opcode and length fields.
const RECORD_HEADER_BYTES: usize = 1 + 8;

/// The end of the last whole top-level record (byte offset), walking the records' lengths from
/// the magic: where a truncated file stops being whole.
fn whole_records_end(bytes: &[u8]) -> usize {
    whole_records_end_from(bytes, mcap::MAGIC.len())
}

/// [`whole_records_end`] from byte `at` on.
fn whole_records_end_from(bytes: &[u8], mut at: usize) -> usize {
    while let Some(header) = bytes.get(at..at + RECORD_HEADER_BYTES) {
        let mut length = [0u8; 8];
        length.copy_from_slice(&header[1..]);
        let end = usize::try_from(u64::from_le_bytes(length))
            .ok()
            .and_then(|n| (at + RECORD_HEADER_BYTES).checked_add(n))
            .filter(|&end| end <= bytes.len());
        match end {
            Some(end) => at = end,
            None => break,
        }
    }
    at.min(bytes.len())
}

/// Decompressed chunks larger than this are taken as damage (our recorder writes 256 KiB).
const MAX_CHUNK_BYTES: u64 = 256 << 20;

/// The length of the file's prefix that the `mcap` reader can be given: everything up to the
/// first record that runs past the end of the file, or the first chunk that does not parse,
/// does not decompress to its stated size and CRC, or whose records do not fit in it.
fn sound_prefix(bytes: &[u8]) -> usize {
    let mut at = mcap::MAGIC.len();
    while let Some(header) = bytes.get(at..at + RECORD_HEADER_BYTES) {
        let mut length = [0u8; 8];
        length.copy_from_slice(&header[1..]);
        let body_start = at + RECORD_HEADER_BYTES;
        let Some(end) = usize::try_from(u64::from_le_bytes(length))
            .ok()
            .and_then(|n| body_start.checked_add(n))
            .filter(|&end| end <= bytes.len())
        else {
            // A record that runs past the end (a cut file, or a damaged length): the stream
            // reader would take whatever the length says, so it stops before it.
            return at;
        };
        // A chunk whose header does not parse is damage too: the stream reader parses it its
        // own way and may size a buffer from what it makes of it.
        let body = &bytes[body_start..end];
        match mcap::read::parse_record(header[0], body) {
            Ok(mcap::records::Record::Chunk { header, data }) if !chunk_holds_together(&header, &data) => {
                return at;
            }
            Err(_) if header[0] == mcap::records::op::CHUNK => return at,
            _ => {}
        }
        at = end;
    }
    bytes.len()
}

/// Whether a chunk decompresses to its stated size (and CRC, when it has one) and its records
/// each fit in what remains of it.
fn chunk_holds_together(header: &mcap::records::ChunkHeader, data: &[u8]) -> bool {
    use std::io::Read;
    if header.uncompressed_size > MAX_CHUNK_BYTES {
        return false;
    }
    let records = match header.compression.as_str() {
        "" => data.to_vec(),
        "zstd" => {
            let Ok(decoder) = zstd::stream::read::Decoder::new(data) else { return false };
            let mut out = Vec::new();
            if decoder.take(header.uncompressed_size + 1).read_to_end(&mut out).is_err() {
                return false;
            }
            out
        }
        // The reader refuses what it cannot decompress without sizing anything from it.
        _ => return true,
    };
    if records.len() as u64 != header.uncompressed_size
        || (header.uncompressed_crc != 0 && crc32fast::hash(&records) != header.uncompressed_crc)
    {
        return false;
    }
    whole_records_end_from(&records, 0) == records.len()
}

/// The message count of the file's statistics record, when its summary section is readable.
fn expected_messages(bytes: &[u8]) -> Option<u64> {
    mcap::Summary::read(bytes).ok().flatten().and_then(|s| s.stats).map(|s| s.message_count)
}
