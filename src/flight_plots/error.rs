//! What can go wrong turning a flight log into plots. Every variant names the file involved.

use std::path::PathBuf;

use crate::recorder::RecorderError;

/// A `kestrel report` failure.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The log could not be opened or one of its topics could not be read.
    #[error(transparent)]
    Log(#[from] RecorderError),

    /// The log lacks a message type the report cannot do without.
    #[error(
        "flight log {} has no `{type_name}` messages, needed for {needed_for} (its topics: {})",
        path.display(),
        available.join(", ")
    )]
    MissingTopic { path: PathBuf, type_name: &'static str, needed_for: &'static str, available: Vec<String> },

    /// The estimator never anchored its local frame (no good GPS fix, or it never aligned), so
    /// there is no frame to compare positions in.
    #[error("flight log {}: no `kestrel.NavState` has an origin; the estimator never aligned", path.display())]
    NoOrigin { path: PathBuf },

    /// The output directory could not be created.
    #[error("cannot create the report directory {}: {source}", path.display())]
    CreateDir { path: PathBuf, source: std::io::Error },

    /// The embedded font did not load (a corrupt build).
    #[error("the embedded plot font (DejaVu Sans) is not a valid font")]
    Font,

    /// Drawing or encoding a plot failed.
    #[error("cannot draw plot {}: {message}", path.display())]
    Draw { path: PathBuf, message: String },

    /// The summary could not be written.
    #[error("cannot write the report summary {}: {source}", path.display())]
    WriteSummary { path: PathBuf, source: std::io::Error },
}
