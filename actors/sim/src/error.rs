//! Typed configuration errors: a bad vehicle or world file names the file and the field.

use std::path::PathBuf;

/// A parameter that is out of range, named by its path in the config (e.g. `motor.time_constant_s`).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("`{field}` {reason}")]
pub struct InvalidParam {
    /// Dotted path of the offending field.
    pub field: String,
    /// What is wrong with it, for a person.
    pub reason: String,
}

impl InvalidParam {
    pub(crate) fn new(field: impl Into<String>, reason: impl Into<String>) -> InvalidParam {
        InvalidParam { field: field.into(), reason: reason.into() }
    }

    /// Prefixes the field path with the table it sits in.
    pub(crate) fn within(mut self, table: &str) -> InvalidParam {
        self.field = format!("{table}.{}", self.field);
        self
    }
}

/// Why a vehicle or world file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("cannot read {}: {source}", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot parse {}: {source}", path.display())]
    Parse {
        path: PathBuf,
        #[source]
        source: toml::de::Error,
    },
    #[error("invalid {}: {source}", path.display())]
    Invalid {
        path: PathBuf,
        #[source]
        source: InvalidParam,
    },
    /// A bad entry of an array of tables (`[[faults]]`), at the line of its header (1-based).
    #[error("invalid {}:{line}: {source}", path.display())]
    InvalidAt {
        path: PathBuf,
        line: usize,
        #[source]
        source: InvalidParam,
    },
}

/// Checks that `value` is finite and strictly positive.
pub(crate) fn positive(field: &str, value: f64) -> Result<(), InvalidParam> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(InvalidParam::new(field, format!("must be a positive number, got {value}")))
    }
}

/// Checks that `value` is a rate in `(0, MAX_RATE_HZ]` (Hz): a faster one would schedule
/// samples a microsecond apart and size delay queues for millions of them.
pub(crate) fn rate(field: &str, value: f64) -> Result<(), InvalidParam> {
    let max = kestrel_proto::timing::MAX_RATE_HZ;
    if value.is_finite() && value > 0.0 && value <= max {
        Ok(())
    } else {
        Err(InvalidParam::new(field, format!("must be a rate in (0, {max}] Hz, got {value}")))
    }
}

/// Checks that `value` is finite and not negative.
pub(crate) fn non_negative(field: &str, value: f64) -> Result<(), InvalidParam> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(InvalidParam::new(field, format!("must be a finite number ≥ 0, got {value}")))
    }
}

/// Checks that every component of `values` is finite.
pub(crate) fn finite(field: &str, values: &[f64]) -> Result<(), InvalidParam> {
    match values.iter().find(|v| !v.is_finite()) {
        None => Ok(()),
        Some(v) => Err(InvalidParam::new(field, format!("must be finite, got {v}"))),
    }
}
