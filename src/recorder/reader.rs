//! The reading side: [`LogReader`] opens a flight log and reads topics back, typed or raw.
//!
//! The whole file is read into memory and scanned once at open, so a corrupt or truncated log
//! is reported up front (naming the file) and [`LogReader::topics`] is exact even for MCAP
//! files written without a summary section by other tools.

use std::collections::{BTreeMap, BTreeSet};
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
        let mut reader = LogReader { path: path.to_path_buf(), bytes, channels: BTreeMap::new() };
        let mut channels = BTreeMap::new();
        for message in reader.messages() {
            let message = message?;
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
        Ok(reader)
    }

    /// The file being read.
    pub fn path(&self) -> &Path {
        &self.path
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

    /// The file's messages in order, decompressing chunks as it goes.
    fn messages(&self) -> impl Iterator<Item = Result<mcap::Message<'static>, RecorderError>> + '_ {
        let corrupt = |source| RecorderError::Corrupt { path: self.path.clone(), source };
        let (stream, error) = match MessageStream::new(&self.bytes) {
            Ok(stream) => (Some(stream), None),
            Err(e) => (None, Some(corrupt(e))),
        };
        error.map(Err).into_iter().chain(stream.into_iter().flatten().map(move |m| m.map_err(corrupt)))
    }
}
