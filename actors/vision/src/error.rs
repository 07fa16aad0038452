//! The one error type of the crate: every variant names the input or the step that failed.

use std::path::PathBuf;

use kestrel_proto::messages::FrameSizeError;

/// Why a vision step failed.
#[derive(Debug, thiserror::Error)]
pub enum VisionError {
    /// An OpenCV call failed; `what` names the step and its input.
    #[error("{what}: {source}")]
    OpenCv {
        what: String,
        #[source]
        source: opencv::Error,
    },
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A file was read but its content is unusable (not an image, a corrupt calibration, …).
    #[error("{}: {what}", path.display())]
    BadFile { path: PathBuf, what: String },
    /// A parameter is out of range or inconsistent.
    #[error("invalid parameter: {0}")]
    Params(String),
    /// An input (frame, image pair, corner set) does not fit what the step needs.
    #[error("{0}")]
    Input(String),
}

impl From<FrameSizeError> for VisionError {
    /// A frame whose images do not fit its size is a bad input.
    fn from(e: FrameSizeError) -> VisionError {
        VisionError::Input(e.to_string())
    }
}

/// Adds the name of the failing step to an OpenCV result.
pub(crate) trait CvContext<T> {
    /// Maps an OpenCV error into [`VisionError::OpenCv`] naming `what`.
    fn cv(self, what: &str) -> Result<T, VisionError>;
    /// As [`CvContext::cv`], with the description built only on failure.
    fn cv_with(self, what: impl FnOnce() -> String) -> Result<T, VisionError>;
}

impl<T> CvContext<T> for opencv::Result<T> {
    fn cv(self, what: &str) -> Result<T, VisionError> {
        self.map_err(|source| VisionError::OpenCv { what: what.to_owned(), source })
    }

    fn cv_with(self, what: impl FnOnce() -> String) -> Result<T, VisionError> {
        self.map_err(|source| VisionError::OpenCv { what: what(), source })
    }
}
