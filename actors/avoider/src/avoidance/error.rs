//! Why the avoider could not be built, or refused a depth grid or a setpoint.

use kestrel_proto::Time;

use crate::error::{InputError, LoadError};

/// A parameter outside its domain.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field} = {value}: expected {expected}")]
pub struct ParamsError {
    pub field: &'static str,
    pub value: f64,
    pub expected: &'static str,
}

/// The avoider could not be built.
#[derive(Debug, thiserror::Error)]
pub enum AvoiderError {
    #[error("avoider parameters: {0}")]
    Params(#[from] ParamsError),
    #[error("avoider rule base: {0}")]
    RuleBase(#[from] LoadError),
    /// The rule base lacks an input or output the avoider feeds or reads.
    #[error("avoider rule base '{rule_base}' has no {role} variable '{name}'")]
    MissingVariable { rule_base: String, role: &'static str, name: &'static str },
    /// The rule base has inputs the avoider cannot feed.
    #[error("avoider rule base '{rule_base}' has {got} inputs; the avoider feeds exactly {expected}")]
    InputCount { rule_base: String, expected: usize, got: usize },
    /// The rule base's rule count differs from table 3.1's.
    #[error("avoider rule base '{rule_base}' has {got} rules; the avoider logs exactly {expected}")]
    RuleCount { rule_base: String, expected: usize, got: usize },
}

/// A depth grid the avoider refused; the previous grid keeps ageing.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GridError {
    /// A region's share is NaN, infinite or outside 0..1.
    #[error("depth grid region [{row}][{col}]: {field} = {value} is not a share in 0..1")]
    BadShare { row: usize, col: usize, field: &'static str, value: f32 },
    /// The OBSTACLE_DISTANCE sectors' geometry is unusable: an increment that is not a
    /// finite positive angle, or an offset that is not finite (degrees).
    #[error("depth grid sectors: {field} = {value} is not a usable angle")]
    BadSectors { field: &'static str, value: f32 },
    /// The sectors are not MAVLink's 72 (`OBSTACLE_DISTANCE`'s fixed array).
    #[error("depth grid sectors: {got} distances, expected {expected}")]
    SectorCount { got: usize, expected: usize },
    /// The sectors' reported range is empty, or its top is the "unknown" value (cm).
    #[error("depth grid sectors: range {min_cm}..{max_cm} cm must be increasing and below 65535")]
    SectorRange { min_cm: u16, max_cm: u16 },
    /// The grid is not newer than the last accepted one.
    #[error("depth grid captured at {time} is not newer than the last accepted one ({last})")]
    OutOfOrder { time: Time, last: Time },
    /// The grid was already older than the age limit when it arrived.
    #[error("depth grid is {age_s:.3} s old on arrival (limit {limit_s} s)")]
    TooOld { age_s: f64, limit_s: f64 },
    /// The rule base refused its inputs (cannot happen for a grid that passed the checks).
    #[error("inference: {0}")]
    Inference(#[from] InputError),
}

/// A setpoint the avoider refused; the previous desired speed stays.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SetpointError {
    #[error("setpoint velocity {axis} = {value} is not finite")]
    NotFinite { axis: &'static str, value: f64 },
    #[error("setpoint desired speed {value} m/s is not a finite speed ≥ 0")]
    BadDesiredSpeed { value: f64 },
}
