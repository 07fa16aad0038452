//! What the motors really do, as their ESCs report it (PX4's `esc_status`).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::messages::MAX_MOTORS;
use crate::time::Time;

/// Per-motor thrust the propulsion produces, measured by the ESCs.
///
/// The commander compares it with the commanded outputs to find a motor that stopped
/// (PX4's FailureDetector, `FD_ACT_EN`). A fixed-size array, so publishing never allocates.
/// Hardware without ESC telemetry (Navio2 PWM outputs) has no source of it: the graph simply
/// routes none and the detector idles.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct EscTelemetry {
    /// When the ESCs measured it.
    pub time: Time,
    /// Motors reported, in the frame's motor order (at most [`MAX_MOTORS`]).
    pub count: u8,
    /// Thrust each motor produces as a fraction of one healthy motor's full thrust (0 = none,
    /// 1 = full), the unit the mixer commands in; entries from `count` on are 0. A motor that
    /// lost its propeller or stopped reports 0 whatever it is commanded.
    pub thrust: [f64; MAX_MOTORS],
    /// Each motor's speed (rad/s; ESCs report electrical rpm, which the pole count turns into
    /// this), the ESC range calibration's feedback; entries from `count` on are 0. It turns with
    /// the propeller off too, when `thrust` is 0.
    #[serde(default)]
    pub speed_rad_s: [f64; MAX_MOTORS],
}
crate::impl_message!(EscTelemetry);
