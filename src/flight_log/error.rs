//! Why a flight log could not be read. Every variant names the file, and a topic or field where
//! one is at fault, so a bench config or a `kestrel replay` pointed at the wrong log says which.

use std::path::PathBuf;

use crate::recorder::RecorderError;

/// A flight-log reading failure.
#[derive(Debug, thiserror::Error)]
pub enum FlightLogError {
    #[error("cannot read flight log {}: {source}", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },

    /// The ULog parser needs a path it can pass on as text.
    #[error("flight log path {} is not valid UTF-8", path.display())]
    Path { path: PathBuf },

    /// The file starts as neither a ULog nor an MCAP file does (empty, another format).
    #[error(
        "{} is neither a PX4 ULog nor a Kestrel MCAP log (it starts with neither's magic; {bytes} bytes)",
        path.display()
    )]
    NotALog { path: PathBuf, bytes: u64 },

    /// The ULog parser (the px4-ulog crate) gave up on a damaged file by panicking: contained
    /// here, never passed on as a crash of the replay.
    #[error("ULog {} is damaged where the parser cannot follow it: {reason}", path.display())]
    Unparsable { path: PathBuf, reason: String },

    /// The MCAP reader's error (it names the file and topic).
    #[error(transparent)]
    Mcap(#[from] RecorderError),

    /// A ULog topic or field a sensor or reference needs is missing.
    #[error(
        "ULog {} lacks topic `{topic}`{}",
        path.display(),
        field.as_ref().map(|f| format!(" field `{f}`")).unwrap_or_default()
    )]
    Missing { path: PathBuf, topic: String, field: Option<String> },

    /// A topic asked for by name is not in the log.
    #[error("flight log {} has no topic `{topic}` (it has: {})", path.display(), available.join(", "))]
    UnknownTopic { path: PathBuf, topic: String, available: Vec<String> },

    /// The topic holds something other than sensor samples.
    #[error(
        "flight log {}: topic `{topic}` holds `{found}`, which is not a sensor sample that can be replayed ({})",
        path.display(),
        replayable.join(", ")
    )]
    NotReplayable { path: PathBuf, topic: String, found: String, replayable: Vec<String> },
}
