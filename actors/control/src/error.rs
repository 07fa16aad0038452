//! Errors of the control crate: bad parameters, bad inputs, bad mission files.

use std::path::PathBuf;

/// A parameter outside its valid range, named by its path in the params table.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("parameter `{name}`: {reason}")]
pub struct InvalidParam {
    /// Dotted path, e.g. `rate.roll.p`.
    pub name: String,
    pub reason: String,
}

impl InvalidParam {
    pub(crate) fn new(name: impl Into<String>, reason: impl Into<String>) -> InvalidParam {
        InvalidParam { name: name.into(), reason: reason.into() }
    }
}

/// Checks that `value` is finite and strictly positive.
pub(crate) fn positive(name: &str, value: f64) -> Result<(), InvalidParam> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(InvalidParam::new(name, format!("must be finite and > 0, got {value}")))
    }
}

/// Checks that `value` is finite and not negative.
pub(crate) fn non_negative(name: &str, value: f64) -> Result<(), InvalidParam> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(InvalidParam::new(name, format!("must be finite and >= 0, got {value}")))
    }
}

/// Checks that `value` lies in `lo..=hi`.
pub(crate) fn within(name: &str, value: f64, lo: f64, hi: f64) -> Result<(), InvalidParam> {
    if value.is_finite() && (lo..=hi).contains(&value) {
        Ok(())
    } else {
        Err(InvalidParam::new(name, format!("must be within {lo}..={hi}, got {value}")))
    }
}

/// Why an input to the loop was rejected (the loop counts these and keeps its last good input).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum RejectedInput {
    #[error("setpoint holds a non-finite value")]
    NonFiniteSetpoint,
    #[error("setpoint thrust outside 0..1")]
    ThrustOutOfRange,
    #[error("navigation state holds a non-finite value")]
    NonFiniteNavState,
    #[error("setpoint names failed motor {0} (0-based), which the frame does not have")]
    NoSuchMotor(usize),
}

/// A QGroundControl `.plan` file that cannot be flown.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    #[error("cannot read mission plan {path}: {source}")]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("mission plan is not valid QGroundControl JSON: {0}")]
    Json(#[from] serde_json::Error),
    #[error("mission plan: file type is `{0}`, expected `Plan`")]
    NotAPlan(String),
    #[error("mission item {index}: {reason}")]
    Item { index: usize, reason: String },
    /// What was wrong in the plan file at `path`, so an error names the file the person wrote
    /// and not the graph config that carried its name.
    #[error("{path}: {source}")]
    InFile {
        path: PathBuf,
        #[source]
        source: Box<PlanError>,
    },
}
