//! Pulses asked of the motor outputs directly, bypassing the mixer: the one way an ESC range
//! calibration drives the ESCs (PX4's `actuator_test`, ArduPilot's MAV_CMD_DO_MOTOR_TEST in PWM).
//! Every consumer checks and times it out through [`crate::esc::DirectPulses`].

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::messages::MAX_MOTORS;
use crate::time::Time;

/// Direct pulses for every output, repeated while wanted: a consumer falls back to the disarmed
/// pulse when none arrives for [`crate::esc::DIRECT_PULSE_TIMEOUT`], and ignores them while armed.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct EscPulses {
    pub time: Time,
    /// `true` drives `pulses_us`; `false` releases the outputs to the disarmed pulse at once
    /// (PX4's `ACTION_RELEASE_CONTROL`).
    pub control: bool,
    /// Pulse width per output in the frame's motor order (µs), each within
    /// [`crate::esc::SAFE_PULSE_MIN_US`]..=[`crate::esc::SAFE_PULSE_MAX_US`] when `control`.
    pub pulses_us: [f64; MAX_MOTORS],
}
crate::impl_message!(EscPulses);
