//! The live parameters an actor owns, as it declares them to the link (topic `param_decl`).
//!
//! Each owner publishes its whole table when it starts and again after every `ParamSet` it
//! handles, so the link always serves the values the owner really flies with (a refused change
//! comes back as the old value).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// One named, bounded parameter (MAVLink type REAL32).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ParamInfo {
    /// At most 16 ASCII characters (MAVLink's `param_id`), ArduPilot/PX4 style.
    pub name: String,
    /// The value the owner uses now, in `unit`.
    pub value: f64,
    /// Least accepted value, in `unit`.
    pub min: f64,
    /// Greatest accepted value, in `unit`.
    pub max: f64,
    /// SI unit (`m`, `m/s`, `rad/s`, `1/s`, ...); empty for a plain ratio.
    pub unit: String,
    /// What the parameter does, for people reading a parameter list.
    pub description: String,
    /// Whole numbers only (a switch, a motor number): served as MAV_PARAM_TYPE_INT32, as
    /// ArduPilot serves its integer parameters, so that a client setting it as an integer
    /// (MAVSDK's `set_param_int`) gets the type it asked for.
    #[serde(default)]
    pub integer: bool,
    /// Refused while armed (`param_def::WhileArmed::Locked`): an output's pulse range, a
    /// sensor's calibration, the board's trim. The link answers a PARAM_SET of it while armed
    /// with a STATUSTEXT and the value still in force.
    #[serde(default)]
    pub disarmed_only: bool,
}

/// Every live parameter of one actor, with its current value.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ParamDecl {
    pub time: Time,
    /// The declaring actor's name in the config; a later declaration of the same owner
    /// replaces the earlier one.
    pub owner: String,
    /// The owner has just (re)started with its configured values: the link answers with a
    /// `ParamSet` for each value the ground station set earlier or the parameter file holds.
    /// Otherwise this answers a `ParamSet`, and a value other than the one set means the owner
    /// refused it.
    pub start: bool,
    pub params: Vec<ParamInfo>,
}
crate::impl_message!(ParamDecl);
