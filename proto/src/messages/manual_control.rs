//! Pilot sticks, from an RC receiver or MAVLink `MANUAL_CONTROL`.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// Normalised stick positions, mode-2 layout.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ManualControl {
    pub time: Time,
    /// Right stick left/right, -1..1 (right positive): roll.
    pub roll: f64,
    /// Right stick forward/back, -1..1 (forward positive): pitch nose-down, fly forward.
    pub pitch: f64,
    /// Left stick left/right, -1..1 (right positive): yaw clockwise seen from above.
    pub yaw: f64,
    /// Left stick up/down, 0..1 (0 = bottom).
    pub throttle: f64,
}
crate::impl_message!(ManualControl);
