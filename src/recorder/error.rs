//! What can go wrong writing or reading a flight log. Every variant names the file, because a
//! run may write several logs and a tool may read many.

use std::path::PathBuf;

/// A recorder or log-reader failure.
#[derive(Debug, thiserror::Error)]
pub enum RecorderError {
    /// The log file could not be created (missing directory, no permission, read-only disk).
    #[error("cannot create flight log {}: {source}", path.display())]
    Create { path: PathBuf, source: std::io::Error },

    /// The writer thread could not be started.
    #[error("cannot start the writer thread for flight log {}: {source}", path.display())]
    Spawn { path: PathBuf, source: std::io::Error },

    /// Writing MCAP records failed (disk full, I/O error). Messages that reached the writer
    /// after the failure were not recorded; `lost` counts them.
    #[error("writing flight log {} failed: {} ({lost} messages not recorded)", path.display(), cause(source))]
    Write { path: PathBuf, source: mcap::McapError, lost: u64 },

    /// Flushing or syncing the finished file to the disk failed.
    #[error("closing flight log {} failed: {source}", path.display())]
    Close { path: PathBuf, source: std::io::Error },

    /// The writer thread panicked; the file is incomplete.
    #[error("the writer thread of flight log {} panicked; the file is incomplete", path.display())]
    WriterPanicked { path: PathBuf },

    /// A topic was registered again with a different message type.
    #[error(
        "flight log {}: topic `{topic}` is already recorded as `{registered}`, cannot record it as `{requested}`",
        path.display()
    )]
    TopicTypeConflict { path: PathBuf, topic: String, registered: String, requested: String },

    /// Two different Rust types claim the same schema name but generate different schemas.
    #[error(
        "flight log {}: two message types are named `{type_name}` but have different schemas",
        path.display()
    )]
    SchemaConflict { path: PathBuf, type_name: String },

    /// A type's JSON Schema could not be serialised.
    #[error("flight log {}: cannot encode the schema of `{type_name}`: {source}", path.display())]
    SchemaEncode { path: PathBuf, type_name: String, source: serde_json::Error },

    /// More topics or types than an MCAP file can index (65 535 each).
    #[error("flight log {}: too many {what} (an MCAP file holds at most 65535)", path.display())]
    TooManyIds { path: PathBuf, what: &'static str },

    /// The log file could not be read.
    #[error("cannot read flight log {}: {source}", path.display())]
    Open { path: PathBuf, source: std::io::Error },

    /// The file does not start as an MCAP file does (empty, another format).
    #[error("flight log {} is not an MCAP file (it does not start with the MCAP magic; {bytes} bytes)", path.display())]
    NotMcap { path: PathBuf, bytes: u64 },

    /// The MCAP reader refused the file where no damage is tolerated.
    #[error("flight log {} is not a valid MCAP file: {source}", path.display())]
    Corrupt { path: PathBuf, source: mcap::McapError },

    /// A topic asked for by name is not in the log.
    #[error("flight log {} has no topic `{topic}` (it has: {})", path.display(), available.join(", "))]
    UnknownTopic { path: PathBuf, topic: String, available: Vec<String> },

    /// A topic holds a different message type than the one asked for.
    #[error(
        "flight log {}: topic `{topic}` holds `{found}`, not the requested `{expected}`",
        path.display()
    )]
    TypeMismatch { path: PathBuf, topic: String, expected: String, found: String },

    /// A topic's messages are not JSON (the log was written by another tool).
    #[error(
        "flight log {}: topic `{topic}` is encoded as `{encoding}`, only `json` is supported",
        path.display()
    )]
    UnsupportedEncoding { path: PathBuf, topic: String, encoding: String },

    /// A message's JSON does not decode into the requested type.
    #[error(
        "flight log {}: message {sequence} on topic `{topic}` does not decode as `{type_name}`: {source}",
        path.display()
    )]
    Decode { path: PathBuf, topic: String, type_name: String, sequence: u32, source: serde_json::Error },
}

/// The most telling text of an MCAP error: for I/O failures the OS's own words ("No space left
/// on device"), which `mcap`'s generic I/O message hides one level down.
pub(super) fn cause(error: &mcap::McapError) -> String {
    match error {
        mcap::McapError::Io(io) => io.to_string(),
        other => other.to_string(),
    }
}
