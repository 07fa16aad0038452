//! Commands to the commander, from the ground station, a script or the CLI.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::follow_target::FollowTarget;
use super::guided_target::{AttitudeTarget, PositionTarget};
use super::mission::MissionPoint;
use super::vehicle_status::FlightMode;
use crate::time::Time;

/// One command; the commander answers a command that carries an id with a [`CommandResult`],
/// and every refusal also shows in `VehicleStatus::last_refusal`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Command {
    /// Arm after the pre-arm checks.
    Arm,
    /// Disarm; refused in flight unless `force`.
    Disarm { force: bool },
    /// Switch flight mode (checks that the mode's needs are met).
    SetMode(FlightMode),
    /// Take off to this height above home (m).
    Takeoff { altitude_m: f64 },
    /// Land where the vehicle is.
    Land,
    /// Return to launch.
    ReturnToLaunch,
    /// Start (or restart) the uploaded mission.
    MissionStart,
    /// Go on in AUTO at the mission's landing sequence: the DO_LAND_START item nearest the
    /// vehicle (MAV_CMD_DO_LAND_START, ArduCopter's AUTO RTL); refused without one.
    LandStart,
    /// In ACRO: a full 360° roll.
    Flip,
    /// In GUIDED: fly to this NED position (m) from home.
    GotoNed { position_ned_m: [f64; 3] },
    /// In GUIDED: fly at this NED velocity (m/s).
    VelocityNed { velocity_ned_m_s: [f64; 3] },
    /// In GUIDED: fly this position/velocity/acceleration target with its yaw
    /// (SET_POSITION_TARGET_LOCAL_NED / GLOBAL_INT, resolved to NED by the link).
    PositionTarget(PositionTarget),
    /// In GUIDED: fly this attitude or these body rates (SET_ATTITUDE_TARGET).
    AttitudeTarget(AttitudeTarget),
    /// In GUIDED: stop and hold where the vehicle is, as ArduCopter's GUIDED does when a
    /// SET_POSITION_TARGET_* or SET_ATTITUDE_TARGET cannot be flown (`ModeGuided::init(true)`).
    GuidedStop,
    /// Move home, where RTL returns and what the geofence and mission-relative altitudes are
    /// measured from (MAV_CMD_DO_SET_HOME): to the vehicle's position (`None`) or to `point`.
    /// Accepted in flight, as PX4 and ArduPilot do; a home set this way survives later armings.
    SetHome { point: Option<MissionPoint> },
    /// Switch the geofence failsafe on or off (MAV_CMD_DO_FENCE_ENABLE).
    SetGeofence { enabled: bool },
    /// Make mission item `index` current (MISSION_SET_CURRENT, MAV_CMD_DO_SET_MISSION_CURRENT):
    /// a running mission flies there next, otherwise the next AUTO starts there. `index` counts
    /// the commander's items, so the ground station's item 0 (home) is not one of them.
    SetMissionCurrent { index: u32 },
    /// In AUTO: fly the mission's legs at this horizontal speed from now on (m/s), as a
    /// DO_CHANGE_SPEED mission item does (MAV_CMD_DO_CHANGE_SPEED).
    ChangeSpeed { speed_m_s: f64 },
    /// In AUTO: stop where the vehicle is and hold, keeping the mission's place
    /// (MAV_CMD_DO_PAUSE_CONTINUE 0, QGroundControl's "Pause").
    PauseMission,
    /// In AUTO: go on with the paused mission from where it stopped (DO_PAUSE_CONTINUE 1).
    ContinueMission,
    /// In GUIDED and AUTO: point the nose at `heading_deg` (from north, clockwise) or turn it by
    /// `relative_deg` (clockwise positive) — exactly one of the two (MAV_CMD_CONDITION_YAW).
    Yaw { heading_deg: Option<f64>, relative_deg: Option<f64> },
    /// In GUIDED and AUTO: keep the nose on this point, NED from the estimator's origin (m), or
    /// stop doing so (`None`) (MAV_CMD_DO_SET_ROI_LOCATION, DO_SET_ROI_NONE).
    RegionOfInterest { position_ned_m: Option<[f64; 3]> },
    /// The process is being stopped (SIGTERM, SIGINT, SIGHUP): in the air, land where the
    /// vehicle is and announce it; armed on the ground, disarm. The runtime sends it and exits
    /// once the vehicle is disarmed, so ending the process never stops the motors in flight.
    Shutdown,
    /// A ground station's HEARTBEAT from system `system_id`. Only the one `MAV_GCS_SYSID`
    /// names (and its MANUAL_CONTROL; not other commands, which scripts send too) establishes
    /// and refreshes the data link whose loss is a failsafe; others are counted and ignored.
    Heartbeat { system_id: u8 },
    /// Circle a centre (MAV_CMD_DO_ORBIT): switches to CIRCLE. `radius_m` > 0 flies clockwise
    /// seen from above, < 0 counter-clockwise, NaN the CIRCLE_RADIUS_M default; `speed_m_s` is
    /// the tangential speed (`None`: the CIRCLE_RATE_DEGS rate); `centre_ne_m` north and east of
    /// the estimator's origin (`None`: where the vehicle is), `centre_down_m` its down
    /// coordinate (`None`: the height flown), both in m.
    Orbit {
        radius_m: f64,
        speed_m_s: Option<f64>,
        yaw: OrbitYaw,
        centre_ne_m: Option<[f64; 2]>,
        centre_down_m: Option<f64>,
    },
    /// Restart the flight stack (MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN 1): while disarmed; armed
    /// only with `force` (ArduPilot's param6 magic 20190226) and on the ground, disarming first.
    /// Once accepted the process exits with `kestrel::reboot::REBOOT_EXIT_CODE`.
    Reboot { force: bool },
    /// Spin motors for a test (MAV_CMD_DO_MOTOR_TEST), only disarmed and landed: motor
    /// `first` (1-based, in the frame's test order: clockwise from the front) and the
    /// `count` - 1 after it in turn, each at `throttle` for `duration_s` (s, at most
    /// `MOTOR_TEST_MAX_S`), with half that at rest between two, as ArduCopter's
    /// `motor_test_output` sequences them.
    MotorTest { first: u8, count: u8, throttle: MotorTestThrottle, duration_s: f64 },
    /// Another system's position report (FOLLOW_TARGET, GLOBAL_POSITION_INT), for FOLLOW.
    FollowTarget(FollowTarget),
}

/// Longest a motor test spins one motor (s): ArduCopter's `MOTOR_TEST_TIMEOUT_SEC`; a longer
/// timeout is cut to it.
pub const MOTOR_TEST_MAX_S: f64 = 600.0;

/// How hard a motor test spins a motor (MAV_CMD_DO_MOTOR_TEST param2 and param3).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum MotorTestThrottle {
    /// Share of the output's range, 0..=1: its `SERVOn_MIN` plus this share of the way to
    /// `SERVOn_MAX` (MOTOR_TEST_THROTTLE_PERCENT / 100).
    Share(f64),
    /// This pulse (µs), within `esc::SAFE_PULSE_MIN_US..=SAFE_PULSE_MAX_US`
    /// (MOTOR_TEST_THROTTLE_PWM).
    PulseUs(f64),
}

/// Where the nose points while orbiting (MAVLink ORBIT_YAW_BEHAVIOUR).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum OrbitYaw {
    /// At the centre (ORBIT_YAW_BEHAVIOUR_HOLD_FRONT_TO_CIRCLE_CENTER, the default).
    #[default]
    FaceCentre,
    /// The heading held when the orbit started (HOLD_INITIAL_HEADING, UNCONTROLLED and
    /// RC_CONTROLLED: no sticks in the loop, so held).
    HoldInitial,
    /// Along the direction of travel (HOLD_FRONT_TANGENT_TO_CIRCLE).
    Tangent,
}

/// A timestamped [`Command`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct VehicleCommand {
    /// Who waits for the answer: the link numbers the MAVLink commands it passes on (from 1) so
    /// that each COMMAND_ACK goes to the command it answers, retries and concurrent ground
    /// stations included. 0: nobody waits (heartbeats, scripts, the CLI) and no result is sent.
    #[serde(default)]
    pub id: u32,
    pub time: Time,
    pub command: Command,
}
crate::impl_message!(VehicleCommand);

/// The commander's answer to the [`VehicleCommand`] with `id`, published as soon as it has
/// handled it: a ground station's command is acknowledged within one graph step, so a client's
/// retry timer (MAVSDK waits 0.5 s before it resends) never runs out while a refusal that reads
/// like the last one goes unnoticed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct CommandResult {
    pub time: Time,
    pub id: u32,
    pub command: Command,
    /// `None`: carried out (armed, mode entered, target taken); otherwise why not.
    pub refusal: Option<String>,
}
crate::impl_message!(CommandResult);
