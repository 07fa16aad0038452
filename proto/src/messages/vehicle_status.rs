//! The commander's account of the vehicle, for the link, the log and the report.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::messages::ClearRangeReason;
use crate::time::Time;

/// Flight modes (ArduPilot's names; PX4's equivalents in the docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum FlightMode {
    /// Sticks set attitude, throttle sets thrust (PX4 Stabilized).
    #[default]
    Stabilize,
    /// Sticks set body rates; `Flip` rolls 360° (PX4 Acro).
    Acro,
    /// Sticks tilt, throttle sets climb rate; altitude held (PX4 Altitude).
    AltHold,
    /// Sticks set velocity; position held when centred (PX4 Position).
    PosHold,
    /// Position/velocity targets from outside (PX4 Offboard).
    Guided,
    /// Fly the uploaded mission (PX4 Mission).
    Auto,
    /// Climb to the take-off altitude and hold.
    Takeoff,
    /// Climb, return home, loiter, descend, land, disarm.
    ReturnToLaunch,
    /// Descend where the vehicle is and disarm on touchdown.
    Land,
    /// Fly a circle around a centre, nose on the centre (ArduCopter CIRCLE, PX4 Orbit; also
    /// what MAV_CMD_DO_ORBIT starts).
    Circle,
    /// Stop as fast as the vehicle can and hold there (ArduCopter BRAKE).
    Brake,
    /// Fly after another system at an offset, from its position reports (ArduCopter FOLLOW).
    Follow,
}

/// Whether the vehicle is on the ground.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum LandedState {
    #[default]
    OnGround,
    InAir,
    Landing,
}

/// What a failsafe does, in increasing precedence (PX4's order).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum FailsafeAction {
    /// Report only.
    Warn,
    /// Hold position (or level and hold altitude without position).
    Hold,
    /// Return to launch.
    ReturnToLaunch,
    /// Land where the vehicle is (level and descend without position).
    Land,
    /// Stop the motors.
    Disarm,
}

/// Why a failsafe fired.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum FailsafeCause {
    /// No heartbeat, command or stick input from the ground station within the timeout.
    DataLinkLost,
    /// Battery below the low threshold.
    BatteryLow,
    /// Battery below the critical threshold.
    BatteryCritical,
    /// Outside the geofence (radius, altitude or polygon).
    GeofenceBreach,
    /// The estimator reports an attitude or position it cannot vouch for.
    EstimatorUnhealthy,
    /// No `NavState` for longer than the stale limit.
    NavStateStale,
    /// A flight-critical actor failed (supervisor report).
    CriticalActorFailed,
    /// A motor stopped producing thrust (ESC telemetry short of its command) and the others
    /// cannot hold every axis without it (PX4's `COM_ACT_FAIL_ACT`).
    MotorFailure,
    /// The pilot's sticks (RC or MAVLink MANUAL_CONTROL) stopped while a mode flown from them
    /// was active (ArduPilot's radio failsafe, PX4's `COM_RC_LOSS_T`).
    ManualControlLost,
    /// The obstacle avoider in the loop has given no fresh correction for longer than its
    /// limit (camera or stereo gone): the stale hold would otherwise last until the battery.
    AvoidanceLost,
}

/// A failsafe that is active now.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct Failsafe {
    pub cause: FailsafeCause,
    pub action: FailsafeAction,
    /// When it fired.
    pub since: Time,
}

/// Mission progress.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct MissionProgress {
    /// Index of the item being flown (== `total` when finished).
    pub current: u32,
    /// Items reached so far.
    pub reached: u32,
    /// Index of the item reached last: after a jump (`SetMissionCurrent`) it is no longer
    /// `reached - 1`.
    #[serde(default)]
    pub last_reached: Option<u32>,
    pub total: u32,
    /// Every item from the current one on is done.
    pub completed: bool,
}

/// Where home is.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Home {
    /// NED from the estimator's origin (m).
    pub position_ned_m: [f64; 3],
    /// Counts every move of home (arming, MAV_CMD_DO_SET_HOME), so that a command is seen to
    /// take effect even when it moves home to where it already was.
    pub revision: u32,
}

/// The forward speed cap the camera's view sets on a leg flown with the avoider:
/// the vehicle must be able to stop inside the distance ahead the view vouches for.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct SpeedCapStatus {
    /// Largest forward speed allowed (m/s).
    pub cap_m_s: f64,
    /// Distance ahead the view vouches for (m).
    pub range_m: f64,
    pub reason: ClearRangeReason,
    /// The cap held the demand below what the leg or the sticks asked for.
    pub limiting: bool,
}

/// What a rangefinder made the commander do vertically (TAKEOFF's climb and LAND's
/// descent, which the forward camera cannot see).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum VerticalLimitKind {
    /// The climb is held below something the upward rangefinder sees overhead.
    Overhead,
    /// The surface under a landing is an obstacle's top, not the ground: the descent waits
    /// above it while the vehicle moves off it.
    ObstacleBelow,
}

impl VerticalLimitKind {
    pub fn as_str(self) -> &'static str {
        match self {
            VerticalLimitKind::Overhead => "obstacle overhead",
            VerticalLimitKind::ObstacleBelow => "obstacle below",
        }
    }
}

/// A vertical limit in force, with the rangefinder's distance to what set it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct VerticalLimitStatus {
    pub kind: VerticalLimitKind,
    /// Vertical distance from the vehicle to the surface (m): above it for `Overhead`, below
    /// for `ObstacleBelow`.
    pub distance_m: f64,
}

/// Published by the commander at its status rate and on every change.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct VehicleStatus {
    pub time: Time,
    pub armed: bool,
    pub mode: FlightMode,
    pub landed: LandedState,
    /// The failsafe with the highest precedence, if any.
    pub failsafe: Option<Failsafe>,
    pub mission: MissionProgress,
    /// Why the last refused command or mode change was refused (for STATUSTEXT).
    pub last_refusal: Option<String>,
    /// Refusals so far: each one is announced, also when it reads like the one before (a
    /// ground station retrying a command it is refused).
    #[serde(default)]
    pub refusals: u32,
    /// Disarmed and the vehicle's own pre-arm checks pass (whatever the mode): SYS_STATUS's
    /// pre-arm bit, which MAVSDK's `is_armable` and ground stations' "ready" read.
    #[serde(default)]
    pub armable: bool,
    /// Home, once the vehicle armed or a ground station set it.
    #[serde(default)]
    pub home: Option<Home>,
    /// Whether a geofence breach triggers its failsafe (MAV_CMD_DO_FENCE_ENABLE).
    #[serde(default = "fence_on")]
    pub geofence_enabled: bool,
    /// The motor (0-based, the frame's motor order) the failure detector declared failed this
    /// flight, from ESC telemetry (PX4's `failure_detector_status`); `None` while every motor
    /// is healthy or nothing reports on them.
    #[serde(default)]
    pub failed_motor: Option<u8>,
    /// The forward speed cap while a leg is flown with the avoider; `None` otherwise. Its
    /// figures move with every depth grid, so only its reason and `limiting` count as a change
    /// of status.
    #[serde(default)]
    pub speed_cap: Option<SpeedCapStatus>,
    /// A rangefinder holding the climb or a landing's descent; `None` otherwise. Its distance
    /// moves with every reading, so only its kind counts as a change of status.
    #[serde(default)]
    pub vertical_limit: Option<VerticalLimitStatus>,
    /// The geofence's breaches, for FENCE_STATUS.
    #[serde(default)]
    pub fence: FenceStatus,
}

/// ArduCopter's `FENCE_TYPE` bit of the altitude ceiling (`FENCE_ALT_MAX`).
pub const FENCE_ALT_MAX: u8 = 1;
/// `FENCE_TYPE` bit of the circle around home (`FENCE_RADIUS`).
pub const FENCE_CIRCLE: u8 = 2;
/// `FENCE_TYPE` bit of the uploaded polygons and circles (and the configured polygon).
pub const FENCE_POLYGON: u8 = 4;
/// `FENCE_TYPE` bit of the altitude floor (`FENCE_ALT_MIN`).
pub const FENCE_ALT_MIN: u8 = 8;

/// The geofence's breach bookkeeping, as ArduCopter's `AC_Fence` keeps it for FENCE_STATUS.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct FenceStatus {
    /// Fences breached now, as `FENCE_TYPE` bits (`FENCE_ALT_MAX` ...); 0 when inside all.
    pub breaches: u8,
    /// Breaches since boot: each fence newly breached counts one (saturating).
    pub breach_count: u16,
    /// When the latest breach began; `None` before the first.
    pub breach_time: Option<Time>,
}

/// The geofence is on unless a ground station switched it off (older logs did not say).
fn fence_on() -> bool {
    true
}
crate::impl_message!(VehicleStatus);
