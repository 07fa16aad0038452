//! Why a log could not be set up for replay. Each variant names the log file and the topic,
//! so a bench config that points at the wrong recording says which and why.

use std::path::PathBuf;

use crate::flight_log::FlightLogError;

/// A `log_replay` set-up failure.
#[derive(Debug, thiserror::Error)]
pub enum LogReplayError {
    /// The log could not be read, a topic in it could not be decoded, is missing or holds no
    /// sensor samples (the reader's error names the file and topic, and lists the log's topics
    /// when one is missing).
    #[error(transparent)]
    Log(#[from] FlightLogError),

    /// `topics` is empty: nothing would be published.
    #[error("`topics` is empty: name the recorded topics to publish from {}", path.display())]
    NoTopics { path: PathBuf },

    /// A topic was named twice in `topics`.
    #[error("`topics` names `{topic}` twice")]
    DuplicateTopic { topic: String },

    /// Two topics of one type would go out on the same output port.
    #[error(
        "flight log {}: topics `{first}` and `{second}` both hold `{type_name}`; log_replay has one output per type (`{port}`), replay one of them",
        path.display()
    )]
    SameType { path: PathBuf, first: String, second: String, type_name: &'static str, port: &'static str },

    /// `speed` is outside the pace range a run allows (`config::SPEEDUP_RANGE`).
    #[error(
        "`speed` must be within {}..={} (log seconds per graph second), got {speed}",
        crate::config::SPEEDUP_RANGE.0,
        crate::config::SPEEDUP_RANGE.1
    )]
    Speed { speed: f64 },
}
