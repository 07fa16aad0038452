//! What a ground station or companion computer asks GUIDED to fly directly: a per-axis
//! position/velocity/acceleration target with yaw (SET_POSITION_TARGET_LOCAL_NED / GLOBAL_INT),
//! or an attitude/body-rate target with thrust or climb rate (SET_ATTITUDE_TARGET).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// A SET_POSITION_TARGET_* resolved to the earth frame by the link: body frames rotated by the
/// heading and offsets added to the position at receipt, as ArduCopter's
/// `handle_message_set_position_target_local_ned` does. Which of position, velocity and
/// acceleration are present is one of ArduCopter's four accepted combinations: position alone,
/// velocity (+ acceleration), acceleration alone, position + velocity (+ acceleration).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct PositionTarget {
    /// NED from the estimator's origin (m).
    pub position_ned_m: Option<[f64; 3]>,
    /// NED (m/s).
    pub velocity_ned_m_s: Option<[f64; 3]>,
    /// NED, gravity excluded (m/s²).
    pub acceleration_ned_m_s2: Option<[f64; 3]>,
    /// Heading to turn to (rad, from north, clockwise); `None` keeps the mode's default.
    pub yaw_rad: Option<f64>,
    /// Heading rate (rad/s, clockwise seen from above); `None` keeps the mode's default.
    pub yaw_rate_rad_s: Option<f64>,
    /// Horizontal speed to fly to the position at (m/s), MAV_CMD_DO_REPOSITION's param1; `None`
    /// uses the controller's limit.
    #[serde(default)]
    pub speed_m_s: Option<f64>,
}

/// A SET_ATTITUDE_TARGET as ArduCopter flies it on its default `GUID_OPTIONS` (0): an attitude
/// with the thrust field read as a climb command, 0.5 holding the height.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct AttitudeTarget {
    /// Quaternion `[w, x, y, z]` rotating body FRD into NED (unit length).
    pub attitude: [f64; 4],
    /// Heading rate feed-forward (rad/s, clockwise seen from above); 0 when the message
    /// ignores its body rates.
    pub yaw_rate_rad_s: f64,
    /// Share of the full climb (positive, up) or descent (negative) rate, -1..1: the message's
    /// thrust `t` (0..1) as `2 (t - 0.5)`.
    pub climb: f64,
}
