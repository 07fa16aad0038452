//! A simulated fault starting or ending (the simulator's `sim_fault` topic), so a log, a plot
//! or a flight report can show when a test broke what, next to how the stack reacted.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// Whether the fault began or ended at `time`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum SimFaultPhase {
    Started,
    Ended,
}

/// One start or end of a fault the simulator injects (a world file's `[[faults]]` entry).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct SimFault {
    /// The simulated time it took effect: the first tick of the simulator at or after its
    /// scheduled start (or end).
    pub time: Time,
    /// Position of the entry in the world file's `[[faults]]` array, from 0.
    pub index: u32,
    pub phase: SimFaultPhase,
    /// The fault's `kind` as the world file spells it (`gps_off`, `motor_weak`, ...).
    pub kind: String,
    /// The kind's values as the world file spells them (`motor = 1, thrust = 0.7`); empty for
    /// kinds without values.
    pub values: String,
    /// Scheduled start (s of simulated time).
    pub at_s: f64,
    /// Scheduled duration (s); `None` until the end of the run.
    pub for_s: Option<f64>,
}
crate::impl_message!(SimFault);
