//! Flight-log recorder and reader (MCAP).
//!
//! Every routed topic can be recorded into one MCAP file, the format Foxglove, the `mcap` CLI
//! and the Python `mcap` package read. Each message is stored as JSON under a JSON Schema
//! generated from its Rust type (schema name = [`Message::TYPE_NAME`]), so a log explains
//! itself to tools that have never seen Kestrel's code.
//!
//! * [`Recorder`] owns a writer thread: actors call [`RecordChannel::record`], which
//!   serialises on the caller's thread and hands the bytes over a queue, so no actor ever waits
//!   on a disk (an SD card can stall for seconds). File I/O and compression happen on the
//!   writer thread.
//! * A log is deterministic: the same sequence of `record` calls gives a bit-identical file
//!   (no wall-clock time, single-threaded compression, ids assigned in registration order), so
//!   a lockstep simulation can be compared byte for byte.
//! * [`LogReader`] reads a log back, typed ([`LogReader::read`]) or raw
//!   ([`LogReader::raw`]) for tools that do not know the types.
//!
//! [`Message::TYPE_NAME`]: kestrel_proto::Message::TYPE_NAME

mod error;
mod format;
pub mod onboard;
mod reader;
pub mod write_watch;
mod writer;

pub use error::RecorderError;
pub use onboard::{OnboardLog, OnboardStatus};
pub use reader::{LogDamage, LogReader, RawRecord, Recorded, TopicInfo};
pub use writer::{RecordChannel, Recorder, RecordingSummary, WriteFailureProbe};
