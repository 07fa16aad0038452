use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// The most motors a frame may have (octocopter).
pub const MAX_MOTORS: usize = 8;

/// Normalised motor commands from the controller's mixer.
///
/// A fixed-size array, so the 400 Hz loop publishes it without allocating.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ActuatorOutputs {
    /// When the controller computed these outputs.
    pub time: Time,
    /// Whether the motors may spin; when false every motor is stopped whatever `motors` says.
    pub armed: bool,
    /// Per-motor command 0..1 (0 = stopped, 1 = full thrust), in the frame's motor order;
    /// entries past the frame's motor count are ignored.
    pub motors: [f64; MAX_MOTORS],
}
crate::impl_message!(ActuatorOutputs);
