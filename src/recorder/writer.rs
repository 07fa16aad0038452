//! The recording side: [`Recorder`] (one per file, owns the writer thread) and
//! [`RecordChannel`] (one per topic, handed to whoever publishes on it).
//!
//! Callers serialise to JSON on their own thread and push the bytes onto a queue; the writer
//! thread alone touches the file. Ids (schemas, channels) are assigned here, in registration
//! order, rather than by the MCAP writer, so registering a channel never waits for the
//! thread and the same registrations always give the same ids.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::marker::PhantomData;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, Sender};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;

use kestrel_proto::{Message, Time};
use mcap::records::MessageHeader;

use super::error::RecorderError;
use super::format::{LIBRARY, MESSAGE_ENCODING, SCHEMA_ENCODING, to_mcap_ns};
use super::onboard::{OnboardLog, OnboardStatus, Segments};

/// Most JSON bytes that may wait for the writer thread. Beyond it `record` drops messages
/// (counted per topic) rather than let a stalled disk eat the companion computer's memory;
/// 64 MiB is minutes of a full graph's output, so a healthy disk never gets near it.
const MAX_QUEUED_BYTES: usize = 64 << 20;

/// Uncompressed bytes per chunk. Smaller than the `mcap` default (1 MiB) so a crash or a
/// power cut loses at most a few seconds of flight, at a small cost in compression.
const CHUNK_SIZE_BYTES: u64 = 256 << 10;

/// Records messages into one MCAP file.
///
/// Create it with [`Recorder::create`], hand a [`RecordChannel`] per topic to the publishers,
/// and call [`Recorder::finish`] at shutdown to write the summary (index, statistics) that
/// lets Foxglove open the file without scanning it. Dropping a `Recorder` without `finish`
/// still closes the file properly, but its errors are only logged.
pub struct Recorder {
    /// The file, for error messages and the summary.
    path: PathBuf,
    /// The queue to the writer thread, shared with every channel.
    queue: Arc<Queue>,
    /// Schemas and channels registered so far, to reuse ids and catch type conflicts.
    registry: Mutex<Registry>,
    /// The writer thread; `None` once joined.
    thread: Option<JoinHandle<WriterOutcome>>,
}

/// Records messages of type `T` on one topic. Cheap to clone; `Send + Sync`.
pub struct RecordChannel<T> {
    channel: Arc<ChannelState>,
    /// `fn(&T)` keeps the handle `Send + Sync` whatever `T` is: it only borrows messages.
    message_type: PhantomData<fn(&T)>,
}

/// What a finished recording holds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RecordingSummary {
    /// The file written.
    pub path: PathBuf,
    /// Messages written, per topic (every registered topic, zero if it stayed silent).
    pub messages_per_topic: BTreeMap<String, u64>,
    /// Messages `record` was given but could not record, per topic (only topics with drops):
    /// the queue was full, the message did not serialise, or the recorder had finished.
    pub dropped_per_topic: BTreeMap<String, u64>,
    /// Size of the finished file (bytes).
    pub file_size_bytes: u64,
}

/// The queue from every channel to the writer thread.
struct Queue {
    path: PathBuf,
    sender: Sender<Command>,
    /// JSON bytes sent but not yet taken by the writer thread, to bound memory.
    queued_bytes: AtomicUsize,
    /// The writer thread's first write failure, set the moment it happens so that the runtime
    /// can report it at once ([`WriteFailureProbe`]) rather than at [`Recorder::finish`].
    failure: Mutex<Option<String>>,
}

/// Tells whether the recorder's writer has failed, from any thread; see
/// [`Recorder::failure_probe`].
#[derive(Clone)]
pub struct WriteFailureProbe {
    queue: Arc<Queue>,
}

impl WriteFailureProbe {
    /// The first write failure (the file and the error), once there has been one.
    pub fn failure(&self) -> Option<String> {
        self.queue.failure.lock().unwrap_or_else(PoisonError::into_inner).clone()
    }
}

/// One registered topic, shared by all its [`RecordChannel`] clones.
struct ChannelState {
    queue: Arc<Queue>,
    id: u16,
    topic: String,
    type_name: &'static str,
    /// Messages `record` could not hand to the writer thread.
    dropped: AtomicU64,
}

#[derive(Default)]
struct Registry {
    /// Schema name → (schema id, schema JSON).
    schemas: BTreeMap<&'static str, (u16, Vec<u8>)>,
    /// Topic → its channel.
    channels: BTreeMap<String, Arc<ChannelState>>,
}

/// What the writer thread is told to do, in the order callers asked.
enum Command {
    Schema { id: u16, name: &'static str, data: Vec<u8> },
    Channel { id: u16, schema_id: u16, topic: String },
    Message { channel_id: u16, log_time: Time, publish_time: Time, data: Vec<u8> },
    Finish,
}

/// The writer thread's account, returned when it ends.
struct WriterOutcome {
    /// Messages written per channel id.
    written: BTreeMap<u16, u64>,
    /// Messages that reached the thread but were not written, per channel id: those after a
    /// write failure, and those queued behind `Finish` by a publisher racing the shutdown.
    unwritten: BTreeMap<u16, u64>,
    /// The first failure, if any.
    result: Result<u64, WriterFailure>,
}

pub(super) enum WriterFailure {
    Mcap(mcap::McapError),
    Io(std::io::Error),
}

/// Where the writer thread puts what it is given: one MCAP file ([`Recorder::create`]) or the
/// vehicle's numbered logs ([`Recorder::onboard`], `onboard::Segments`).
pub(super) trait Sink: Send {
    fn schema(&mut self, id: u16, name: &'static str, data: &[u8]) -> Result<(), mcap::McapError>;
    fn channel(&mut self, id: u16, schema_id: u16, topic: &str) -> Result<(), mcap::McapError>;
    /// Writes one message; `Ok(false)` when no log is open to keep it (the onboard log between
    /// flights), which is not a loss.
    fn message(&mut self, header: &MessageHeader, data: &[u8]) -> Result<bool, mcap::McapError>;
    /// Finishes what is open; the size of the file closed (0 if none).
    fn close(self: Box<Self>) -> Result<u64, WriterFailure>;
}

/// One MCAP file for the whole run.
struct SingleFile(mcap::Writer<BufWriter<File>>);

impl Sink for SingleFile {
    fn schema(&mut self, id: u16, name: &'static str, data: &[u8]) -> Result<(), mcap::McapError> {
        self.0.add_schema_with_id(id, name, SCHEMA_ENCODING, data).map(drop)
    }

    fn channel(&mut self, id: u16, schema_id: u16, topic: &str) -> Result<(), mcap::McapError> {
        self.0.add_channel_with_id(id, schema_id, topic, MESSAGE_ENCODING, &BTreeMap::new()).map(drop)
    }

    fn message(&mut self, header: &MessageHeader, data: &[u8]) -> Result<bool, mcap::McapError> {
        self.0.write_to_known_channel(header, data).map(|()| true)
    }

    fn close(self: Box<Self>) -> Result<u64, WriterFailure> {
        close_mcap(self.0)
    }
}

/// An MCAP writer on `file` with everything that could differ between two identical runs
/// pinned: the library string carries no build metadata, and compression is single-threaded
/// (zstd's multi-threaded output depends on the worker count, i.e. on the machine).
pub(super) fn mcap_writer(file: File) -> Result<mcap::Writer<BufWriter<File>>, mcap::McapError> {
    mcap::WriteOptions::new()
        .library(LIBRARY)
        .compression(Some(mcap::Compression::Zstd))
        .compression_threads(0)
        .chunk_size(Some(CHUNK_SIZE_BYTES))
        .create(BufWriter::new(file))
}

impl Recorder {
    /// Creates (or truncates) the MCAP file at `path` and starts the writer thread.
    pub fn create(path: &Path) -> Result<Recorder, RecorderError> {
        let file = File::create(path)
            .map_err(|source| RecorderError::Create { path: path.to_path_buf(), source })?;
        let writer = mcap_writer(file).map_err(|source| RecorderError::Write {
            path: path.to_path_buf(),
            source,
            lost: 0,
        })?;
        Recorder::start(path, Box::new(SingleFile(writer)))
    }

    /// Records into the vehicle's numbered logs in `config.dir` (made if absent), one per
    /// arming or one for the run (`onboard`); the status says which log is open and the last
    /// error.
    pub fn onboard(config: OnboardLog) -> Result<(Recorder, Arc<Mutex<OnboardStatus>>), RecorderError> {
        std::fs::create_dir_all(&config.dir)
            .map_err(|source| RecorderError::Create { path: config.dir.clone(), source })?;
        let status = Arc::new(Mutex::new(OnboardStatus::default()));
        let dir = config.dir.clone();
        let recorder = Recorder::start(&dir, Box::new(Segments::new(config, Arc::clone(&status))))?;
        Ok((recorder, status))
    }

    /// Starts the writer thread putting what it is given into `writer`; `path` names the
    /// recording in errors and the summary.
    fn start(path: &Path, writer: Box<dyn Sink>) -> Result<Recorder, RecorderError> {
        let (sender, receiver) = std::sync::mpsc::channel();
        let queue = Arc::new(Queue {
            path: path.to_path_buf(),
            sender,
            queued_bytes: AtomicUsize::new(0),
            failure: Mutex::new(None),
        });
        let thread_queue = Arc::clone(&queue);
        let thread = std::thread::Builder::new()
            .name("recorder".into())
            .spawn(move || run_writer(writer, &receiver, &thread_queue))
            .map_err(|source| RecorderError::Spawn { path: path.to_path_buf(), source })?;
        Ok(Recorder {
            path: path.to_path_buf(),
            queue,
            registry: Mutex::new(Registry::default()),
            thread: Some(thread),
        })
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// A handle that reports the writer's first failure as soon as it happens (a full disk, a
    /// read-only card): the runtime polls it to warn the ground station within a second.
    pub fn failure_probe(&self) -> WriteFailureProbe {
        WriteFailureProbe { queue: Arc::clone(&self.queue) }
    }

    /// Registers `topic` as carrying `T` and returns the handle to record it.
    ///
    /// The topic's schema is `T`'s JSON Schema (encoding `jsonschema`, name `T::TYPE_NAME`),
    /// shared by every topic of that type; messages are encoded as `json`. Registering a topic
    /// again with the same type returns a handle to the same channel; with another type it is
    /// an error.
    pub fn channel<T: Message>(&self, topic: &str) -> Result<RecordChannel<T>, RecorderError> {
        let mut registry = self.registry.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(existing) = registry.channels.get(topic) {
            if existing.type_name != T::TYPE_NAME {
                return Err(RecorderError::TopicTypeConflict {
                    path: self.path.clone(),
                    topic: topic.to_owned(),
                    registered: existing.type_name.to_owned(),
                    requested: T::TYPE_NAME.to_owned(),
                });
            }
            return Ok(RecordChannel::new(Arc::clone(existing)));
        }
        let schema_id = self.schema_id::<T>(&mut registry)?;
        let id = next_id(registry.channels.len(), &self.path, "topics")?;
        let channel = Arc::new(ChannelState {
            queue: Arc::clone(&self.queue),
            id,
            topic: topic.to_owned(),
            type_name: T::TYPE_NAME,
            dropped: AtomicU64::new(0),
        });
        registry.channels.insert(topic.to_owned(), Arc::clone(&channel));
        // A dead writer thread is reported by `finish`; the handle then just counts drops.
        let _ = self.queue.sender.send(Command::Channel { id, schema_id, topic: topic.to_owned() });
        Ok(RecordChannel::new(channel))
    }

    /// The id of `T`'s schema, registering it on first use.
    fn schema_id<T: Message>(&self, registry: &mut Registry) -> Result<u16, RecorderError> {
        let schema = schemars::generate::SchemaSettings::draft2020_12()
            .for_serialize()
            .with(|settings| settings.inline_subschemas = true)
            .into_generator()
            .into_root_schema_for::<T>();
        let data = serde_json::to_vec(&schema).map_err(|source| RecorderError::SchemaEncode {
            path: self.path.clone(),
            type_name: T::TYPE_NAME.to_owned(),
            source,
        })?;
        if let Some((id, known)) = registry.schemas.get(T::TYPE_NAME) {
            return if *known == data {
                Ok(*id)
            } else {
                Err(RecorderError::SchemaConflict {
                    path: self.path.clone(),
                    type_name: T::TYPE_NAME.to_owned(),
                })
            };
        }
        let id = next_id(registry.schemas.len(), &self.path, "message types")?;
        registry.schemas.insert(T::TYPE_NAME, (id, data.clone()));
        let _ = self.queue.sender.send(Command::Schema { id, name: T::TYPE_NAME, data });
        Ok(id)
    }

    /// Writes the remaining messages and the summary section, syncs the file to disk, stops
    /// the writer thread and reports what was recorded.
    ///
    /// Messages recorded after this call are dropped (and logged), never a panic.
    pub fn finish(mut self) -> Result<RecordingSummary, RecorderError> {
        let outcome = self.stop()?;
        let registry = self.registry.lock().unwrap_or_else(PoisonError::into_inner);
        let dropped_before_finish: u64 =
            registry.channels.values().map(|c| c.dropped.load(Ordering::Relaxed)).sum();
        let file_size_bytes = match outcome.result {
            Ok(size) => size,
            Err(failure) => {
                let lost = outcome.unwritten.values().sum::<u64>() + dropped_before_finish;
                return Err(match failure {
                    WriterFailure::Mcap(source) => {
                        RecorderError::Write { path: self.path.clone(), source, lost }
                    }
                    WriterFailure::Io(source) => RecorderError::Close { path: self.path.clone(), source },
                });
            }
        };
        let mut messages_per_topic = BTreeMap::new();
        let mut dropped_per_topic = BTreeMap::new();
        for (topic, channel) in &registry.channels {
            let written = outcome.written.get(&channel.id).copied().unwrap_or(0);
            messages_per_topic.insert(topic.clone(), written);
            let dropped = channel.dropped.load(Ordering::Relaxed)
                + outcome.unwritten.get(&channel.id).copied().unwrap_or(0);
            if dropped > 0 {
                dropped_per_topic.insert(topic.clone(), dropped);
            }
        }
        Ok(RecordingSummary {
            path: self.path.clone(),
            messages_per_topic,
            dropped_per_topic,
            file_size_bytes,
        })
    }

    /// Tells the writer thread to finish and waits for it. Runs once: `finish` consumes the
    /// recorder and `drop` skips an already stopped one, so the thread is always there.
    fn stop(&mut self) -> Result<WriterOutcome, RecorderError> {
        let thread =
            self.thread.take().ok_or_else(|| RecorderError::WriterPanicked { path: self.path.clone() })?;
        // If the thread is gone its receiver is too and this fails; `join` tells why.
        let _ = self.queue.sender.send(Command::Finish);
        thread.join().map_err(|_| RecorderError::WriterPanicked { path: self.path.clone() })
    }
}

impl Drop for Recorder {
    /// Closes the file if [`Recorder::finish`] was not called, logging what went wrong.
    fn drop(&mut self) {
        if self.thread.is_none() {
            return;
        }
        match self.stop() {
            Ok(WriterOutcome { result: Err(WriterFailure::Mcap(e)), .. }) => {
                tracing::error!(path = %self.path.display(), "flight log write failed: {e}")
            }
            Ok(WriterOutcome { result: Err(WriterFailure::Io(e)), .. }) => {
                tracing::error!(path = %self.path.display(), "flight log close failed: {e}")
            }
            Ok(_) => {}
            Err(e) => tracing::error!("{e}"),
        }
    }
}

/// The next 1-based id after `count` registered ones; MCAP ids are `u16` and 0 means "none".
fn next_id(count: usize, path: &Path, what: &'static str) -> Result<u16, RecorderError> {
    u16::try_from(count + 1).map_err(|_| RecorderError::TooManyIds { path: path.to_path_buf(), what })
}

impl<T> Clone for RecordChannel<T> {
    fn clone(&self) -> Self {
        RecordChannel::new(Arc::clone(&self.channel))
    }
}

impl<T> RecordChannel<T> {
    fn new(channel: Arc<ChannelState>) -> Self {
        RecordChannel { channel, message_type: PhantomData }
    }

    /// The topic this handle records.
    pub fn topic(&self) -> &str {
        &self.channel.topic
    }

    /// Messages this topic could not record so far (queue full, unserialisable, or recorded
    /// after the recorder finished).
    pub fn dropped(&self) -> u64 {
        self.channel.dropped.load(Ordering::Relaxed)
    }
}

impl<T: Message> RecordChannel<T> {
    /// Records `msg`, received at `log_time` (the graph clock when the router saw it); its
    /// publish time is `msg.time()`, when it was measured.
    ///
    /// Serialises on the calling thread and queues the bytes; never waits for the disk. A
    /// message that cannot be queued is counted in [`RecordChannel::dropped`] and in the
    /// recording summary, and the first drop per topic is logged.
    pub fn record(&self, log_time: Time, msg: &T) {
        let channel = &self.channel;
        let data = match serde_json::to_vec(msg) {
            Ok(data) => data,
            Err(e) => return channel.drop_message(&format!("does not serialise: {e}")),
        };
        let len = data.len();
        let queue = &channel.queue;
        if queue.queued_bytes.fetch_add(len, Ordering::Relaxed) + len > MAX_QUEUED_BYTES {
            queue.queued_bytes.fetch_sub(len, Ordering::Relaxed);
            return channel.drop_message("the writer is too far behind");
        }
        let command = Command::Message { channel_id: channel.id, log_time, publish_time: msg.time(), data };
        if queue.sender.send(command).is_err() {
            queue.queued_bytes.fetch_sub(len, Ordering::Relaxed);
            channel.drop_message("the recorder has finished");
        }
    }
}

impl ChannelState {
    fn drop_message(&self, why: &str) {
        if self.dropped.fetch_add(1, Ordering::Relaxed) == 0 {
            tracing::warn!(
                path = %self.queue.path.display(),
                topic = %self.topic,
                "not recording a message: {why} (further drops on this topic are only counted)"
            );
        }
    }
}

/// The writer thread: applies commands in order until told to finish, then closes the file.
/// After a write failure it keeps draining the queue, counting what it could not write, so
/// callers never block and memory stays bounded.
fn run_writer(mut writer: Box<dyn Sink>, commands: &Receiver<Command>, queue: &Queue) -> WriterOutcome {
    let mut written: BTreeMap<u16, u64> = BTreeMap::new();
    let mut unwritten: BTreeMap<u16, u64> = BTreeMap::new();
    let mut failure: Option<mcap::McapError> = None;
    // `recv` fails only if every sender is gone, which the recorder's own handle prevents
    // until it has sent `Finish`.
    while let Ok(command) = commands.recv() {
        let applied = match command {
            Command::Finish => break,
            Command::Message { channel_id, data, .. } if failure.is_some() => {
                queue.queued_bytes.fetch_sub(data.len(), Ordering::Relaxed);
                *unwritten.entry(channel_id).or_insert(0) += 1;
                continue;
            }
            _ if failure.is_some() => continue,
            Command::Schema { id, name, data } => writer.schema(id, name, &data),
            Command::Channel { id, schema_id, topic } => writer.channel(id, schema_id, &topic),
            Command::Message { channel_id, log_time, publish_time, data } => {
                queue.queued_bytes.fetch_sub(data.len(), Ordering::Relaxed);
                let count = written.entry(channel_id).or_insert(0);
                // Per-channel sequence numbers, 0-based, in write order.
                let sequence = u32::try_from(*count).unwrap_or(u32::MAX);
                let header = MessageHeader {
                    channel_id,
                    sequence,
                    log_time: to_mcap_ns(log_time),
                    publish_time: to_mcap_ns(publish_time),
                };
                match writer.message(&header, &data) {
                    Ok(true) => {
                        *count += 1;
                        Ok(())
                    }
                    Ok(false) => Ok(()),
                    Err(e) => {
                        *unwritten.entry(channel_id).or_insert(0) += 1;
                        Err(e)
                    }
                }
            }
        };
        if let Err(e) = applied {
            let text = format!("{}: {}", queue.path.display(), super::error::cause(&e));
            *queue.failure.lock().unwrap_or_else(PoisonError::into_inner) = Some(text);
            failure = Some(e);
        }
    }
    for command in commands.try_iter() {
        if let Command::Message { channel_id, data, .. } = command {
            queue.queued_bytes.fetch_sub(data.len(), Ordering::Relaxed);
            *unwritten.entry(channel_id).or_insert(0) += 1;
        }
    }
    let result = match failure {
        Some(e) => Err(WriterFailure::Mcap(e)),
        None => writer.close(),
    };
    WriterOutcome { written, unwritten, result }
}

/// Writes the summary section and footer, flushes and syncs the file; returns its size.
pub(super) fn close_mcap(mut writer: mcap::Writer<BufWriter<File>>) -> Result<u64, WriterFailure> {
    writer.finish().map_err(WriterFailure::Mcap)?;
    let file = writer.into_inner().into_inner().map_err(|e| WriterFailure::Io(e.into_error()))?;
    file.sync_all().map_err(WriterFailure::Io)?;
    let size = file.metadata().map_err(WriterFailure::Io)?.len();
    Ok(size)
}
