//! What the commander asks of the control loop.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// Per-axis trajectory setpoint for the position controller, earth frame NED around home.
///
/// An axis whose position is `None` is not held in position; if its velocity is `None` too, it
/// flies on the acceleration feed-forward alone (that is how ALT_HOLD tilts from the sticks).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct TrajectorySetpoint {
    /// Position north, east, down (m), per axis.
    pub position_ned_m: [Option<f64>; 3],
    /// Velocity north, east, down (m/s), per axis: the target when the position is `None`,
    /// otherwise a feed-forward added to the position loop's output.
    pub velocity_ned_m_s: [Option<f64>; 3],
    /// Acceleration feed-forward north, east, down (m/s²), gravity excluded.
    pub acceleration_ned_m_s2: [f64; 3],
    /// Heading (rad, from north towards east); `None` holds the current heading.
    pub yaw_rad: Option<f64>,
    /// Heading rate feed-forward (rad/s, positive clockwise seen from above).
    pub yaw_rate_rad_s: f64,
    /// Horizontal speed limit for this setpoint (m/s); `None` uses the controller's limit.
    pub max_horizontal_speed_m_s: Option<f64>,
    /// Horizontal speed the flight plan asks for before the obstacle avoider's correction
    /// (m/s): the avoider's `V_in`. The velocity above already carries the correction, so
    /// reading the desire from it would feed the avoider's own braking back as a lower desire.
    /// `None` when no leg is being flown with the avoider: the velocity's norm is the desire.
    #[serde(default)]
    pub desired_speed_m_s: Option<f64>,
}

/// What the loop should track.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum SetpointTarget {
    /// Motors stopped (disarmed, or landed and idle).
    MotorsOff,
    /// Body rates and collective thrust (ACRO, flips).
    Rates {
        /// Angular rate about forward, right, down (rad/s).
        rates_frd_rad_s: [f64; 3],
        /// Collective thrust as a share of the frame's maximum, 0..1.
        thrust: f64,
    },
    /// Attitude and collective thrust (STABILIZE).
    Attitude {
        /// Quaternion `[w, x, y, z]` rotating body FRD into NED.
        attitude: [f64; 4],
        /// Heading rate feed-forward (rad/s).
        yaw_rate_rad_s: f64,
        /// Collective thrust as a share of the frame's maximum, 0..1.
        thrust: f64,
    },
    /// Position/velocity/acceleration per axis (ALT_HOLD, POSHOLD, GUIDED, AUTO, RTL, LAND).
    Trajectory(TrajectorySetpoint),
}

/// The commander's current demand on the control loop; the loop keeps tracking the newest one.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Setpoint {
    /// When the commander produced it (the loop treats an old setpoint as lost).
    pub time: Time,
    /// Whether the motors may spin.
    pub armed: bool,
    pub target: SetpointTarget,
    /// True while the commander is landing the vehicle (for logs and tools); the loop flies
    /// the target like any other.
    pub landing: bool,
    /// The motor (0-based, the frame's motor order) the commander's failure detector declared
    /// failed: the mixer allocates around it (PX4's `failure_detector_status` read by the
    /// control allocator with `CA_FAILURE_MODE = 1`). `None` while every motor is healthy.
    #[serde(default)]
    pub failed_motor: Option<u8>,
}
crate::impl_message!(Setpoint);
