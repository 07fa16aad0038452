//! A parameter changed from the ground station (MAVLink `PARAM_SET`, or the link restoring a
//! persisted value at start), for the actor that owns it (topic `param_set`).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// A parameter's new value, already checked against its range by the link.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ParamSet {
    pub time: Time,
    /// The parameter's name (at most 16 characters, MAVLink's `param_id`).
    pub name: String,
    pub value: f64,
}
crate::impl_message!(ParamSet);
