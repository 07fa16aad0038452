//! Pilot sticks, from an RC receiver or MAVLink `MANUAL_CONTROL`.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// Where a [`ManualControl`] came from. The commander arbitrates between the two (its
/// `PilotInput`): the receiver wins while it is healthy, MAVLink sticks count only from the
/// ground station named by `MAV_GCS_SYSID`, and each source has its own timeout and loss
/// failsafe, so neither can hide the other's loss.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum StickSource {
    /// The RC receiver (SBUS, the Navio2's RCIO, a scripted pilot's radio).
    #[default]
    Radio,
    /// MAVLink `MANUAL_CONTROL` from the system `system_id` (a ground station's joystick).
    Mavlink { system_id: u8 },
}

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
    /// Who sent them. Required on the wire: sticks of unknown origin are not taken as the
    /// receiver's, which would win over every ground station.
    pub source: StickSource,
}
crate::impl_message!(ManualControl);
