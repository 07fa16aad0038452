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
    /// The link restoring the value in force before the owner (re)started (an earlier set or
    /// the parameter file), not a new value: taken even while armed, since the restart
    /// dropped it. A ground station's set is never a restore.
    #[serde(default)]
    pub restore: bool,
}
crate::impl_message!(ParamSet);
