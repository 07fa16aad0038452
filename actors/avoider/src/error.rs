//! Errors: a bad rule file names the file, the line and the cause; a bad input names the input.

use std::path::PathBuf;

/// A rule base that could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The file could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The file's extension says neither FLL nor TOML.
    #[error("{}: unknown rule file format (expected a .fll or .toml file)", path.display())]
    UnknownFormat { path: PathBuf },
    /// The text was read but is not a valid rule base.
    #[error("{origin}:{line}: {cause}")]
    Invalid {
        /// The file (or other source) the text came from.
        origin: String,
        /// 1-based line of the offending definition; 0 when it concerns the whole file.
        line: usize,
        cause: Cause,
    },
}

impl LoadError {
    /// The cause, when the text itself was at fault.
    pub fn cause(&self) -> Option<&Cause> {
        match self {
            LoadError::Invalid { cause, .. } => Some(cause),
            LoadError::Io { .. } | LoadError::UnknownFormat { .. } => None,
        }
    }

    /// The 1-based line, when the text itself was at fault.
    pub fn line(&self) -> Option<usize> {
        match self {
            LoadError::Invalid { line, .. } => Some(*line),
            LoadError::Io { .. } | LoadError::UnknownFormat { .. } => None,
        }
    }
}

/// What was wrong in a rule base.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Cause {
    #[error("syntax error: {0}")]
    Syntax(String),
    #[error("malformed number '{0}'")]
    MalformedNumber(String),
    #[error("defuzzifier resolution {found}: an integral defuzzifier takes 1..={max} samples")]
    Resolution { found: String, max: usize },
    #[error(
        "unknown term type '{0}' (expected one of Gaussian, Triangle, Trapezoid, Bell, Sigmoid, Ramp, Constant)"
    )]
    UnknownTermType(String),
    #[error("term '{term}': {kind} takes {expected} parameters, got {got}")]
    ParameterCount { term: String, kind: &'static str, expected: String, got: usize },
    #[error("term '{term}': {reason}")]
    InvalidTerm { term: String, reason: String },
    #[error(
        "term '{term}' peaks at {peak_lo}..{peak_hi}, outside the range {min}..{max} of variable '{variable}'"
    )]
    TermOutsideRange { variable: String, term: String, peak_lo: f64, peak_hi: f64, min: f64, max: f64 },
    #[error("variable '{variable}': invalid range {min}..{max} (need finite min < max)")]
    InvalidRange { variable: String, min: f64, max: f64 },
    #[error("variable '{0}' has no range")]
    MissingRange(String),
    #[error("'{0}' is defined twice")]
    Duplicate(String),
    #[error("unknown {role} variable '{name}'")]
    UnknownVariable { role: &'static str, name: String },
    #[error("variable '{variable}' has no term '{term}'")]
    UnknownTerm { variable: String, term: String },
    #[error("unknown {what} '{name}' (expected one of {expected})")]
    UnknownName { what: &'static str, name: String, expected: String },
    #[error("output variable '{0}' has no defuzzifier")]
    MissingDefuzzifier(String),
    #[error("output variable '{0}' needs an aggregation operator for its integral defuzzifier")]
    MissingAggregation(String),
    #[error("rule block '{block}' needs {what} for rule '{rule}'")]
    MissingNorm { block: String, what: &'static str, rule: String },
    #[error("output variable '{variable}': {reason}")]
    WeightedKind { variable: String, reason: String },
    #[error("rule '{rule}' can never fire: {reason}")]
    NeverFires { rule: String, reason: String },
    #[error("the rule base has no {0}")]
    Empty(&'static str),
}

/// Inputs that cannot be evaluated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InputError {
    #[error("expected {expected} input values, got {got}")]
    Count { expected: usize, got: usize },
    #[error("input '{0}' is not a number")]
    NotANumber(String),
    #[error("expected NAME=VALUE, got '{0}'")]
    Malformed(String),
    #[error("input '{name}': malformed number '{value}'")]
    MalformedNumber { name: String, value: String },
    #[error("unknown input variable '{0}'")]
    UnknownVariable(String),
    #[error("input '{0}' given twice")]
    Duplicate(String),
    #[error("input '{0}' missing")]
    Missing(String),
    #[error("the workspace was made for a different rule base")]
    ForeignWorkspace,
}
