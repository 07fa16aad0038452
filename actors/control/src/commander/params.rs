//! `CommanderParams`: modes, arming, landing and failsafe settings, with PX4/ArduPilot-like
//! defaults scaled to the thesis's small field (RTL at 15 m, a 300 m fence).

use kestrel_proto::messages::FailsafeAction;
use serde::{Deserialize, Serialize};

use super::circle::CircleParams;
use super::failsafe_actions;
use super::follow::FollowParams;
use super::rally::RallyParams;
use super::vertical::VerticalParams;
use crate::error::{InvalidParam, positive, within};
use crate::motor_failure::{MotorFailureDetector, MotorFailureParams};

/// The commander's parameters (`[actors.commander.params]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CommanderParams {
    /// Collective thrust share that hovers (maps mid-throttle in STABILIZE/ACRO).
    pub hover_thrust: f64,
    /// Stick full deflection in STABILIZE/ALT_HOLD (degrees of tilt).
    pub max_tilt_deg: f64,
    /// Stick full deflection in ACRO (deg/s about forward and right).
    pub acro_rate_deg_s: f64,
    /// Yaw stick full deflection (deg/s).
    pub yaw_rate_deg_s: f64,
    /// Climb/descent rate at full throttle deflection in ALT_HOLD/POSHOLD (m/s).
    pub stick_climb_m_s: f64,
    /// Horizontal speed at full stick in POSHOLD (m/s).
    pub stick_speed_m_s: f64,
    /// Throttle dead band around mid-stick (share of half travel).
    pub throttle_deadband: f64,
    /// Take-off height above home (m).
    pub takeoff_altitude_m: f64,
    /// RTL climbs to at least this height above home (m).
    pub rtl_altitude_m: f64,
    /// RTL return speed (m/s).
    pub rtl_speed_m_s: f64,
    /// RTL loiter above home before landing (s).
    pub rtl_loiter_s: f64,
    /// Descent rate while landing, above `land_slow_height_m` (m/s).
    pub land_fast_m_s: f64,
    /// Descent rate below `land_slow_height_m` (m/s).
    pub land_slow_m_s: f64,
    /// Height above home below which the landing slows (m).
    pub land_slow_height_m: f64,
    /// The land detector trips after this long without vertical motion while landing (s).
    pub land_detect_s: f64,
    /// Least height above home for a flip (m).
    pub flip_min_height_m: f64,
    /// A NavState older than this is stale (s).
    pub nav_timeout_s: f64,
    /// Setpoints are published at least this often (Hz).
    pub setpoint_rate_hz: f64,
    /// `VehicleStatus` is published at least this often (Hz), and on every change.
    pub status_rate_hz: f64,
    /// An `AvoidanceCommand` older than this is stale: AUTO/GUIDED legs slow and hold (s).
    /// Used only once the `avoidance` port has delivered a command.
    pub avoidance_timeout_s: f64,
    /// GUIDED position targets are flown at this speed while the avoider is in the loop (m/s).
    pub guided_speed_m_s: f64,
    /// Arming needs a battery report; false for benches without a power module.
    pub require_battery: bool,
    /// Armed on the ground this long without taking off disarms (s); 0 = never. ArduCopter's
    /// `DISARM_DELAY` and PX4's `COM_DISARM_PRFLT` (both 10 s): a vehicle armed from a ground
    /// station and forgotten must not sit with its motors live.
    pub disarm_delay_s: f64,
    /// A GUIDED velocity target not repeated within this time is dropped and the vehicle holds
    /// (s). ArduCopter's `GUIDED_TIMEOUT` is 3 s; MAVSDK's Offboard repeats its setpoint at 20 Hz.
    pub guided_timeout_s: f64,
    /// The ground station in control (`MAV_GCS_SYSID`, ArduPilot 4.7's name for SYSID_MYGCS;
    /// 255 as there and as QGroundControl and MAVProxy identify themselves): only its
    /// heartbeats and MANUAL_CONTROL hold off the ground-station failsafe, and only its
    /// MANUAL_CONTROL flies (`pilot_input`).
    pub gcs_system_id: u8,
    pub failsafe: FailsafeParams,
    pub geofence: GeofenceParams,
    pub feasibility: FeasibilityParams,
    /// `[vertical]`: the up- and downward rangefinders' limits (`vertical`).
    pub vertical: VerticalParams,
    /// `[circle]`: CIRCLE's radius, rate and acceleration (`circle`).
    pub circle: CircleParams,
    /// `[follow]`: FOLLOW's `FOLL_*` (`follow`).
    pub follow: FollowParams,
    /// `[rally]`: which rally point RTL may return to (`rally`).
    pub rally: RallyParams,
}

impl Default for CommanderParams {
    fn default() -> CommanderParams {
        CommanderParams {
            hover_thrust: 0.3343,
            max_tilt_deg: 30.0,
            acro_rate_deg_s: 220.0,
            yaw_rate_deg_s: 90.0,
            stick_climb_m_s: 2.5,
            stick_speed_m_s: 5.0,
            throttle_deadband: 0.1,
            takeoff_altitude_m: 10.0,
            rtl_altitude_m: 15.0,
            rtl_speed_m_s: 5.0,
            rtl_loiter_s: 2.0,
            land_fast_m_s: 1.5,
            land_slow_m_s: 0.6,
            land_slow_height_m: 4.0,
            land_detect_s: 1.0,
            flip_min_height_m: 5.0,
            nav_timeout_s: 0.05,
            setpoint_rate_hz: 50.0,
            status_rate_hz: 5.0,
            avoidance_timeout_s: 0.5,
            guided_speed_m_s: 5.0,
            require_battery: true,
            disarm_delay_s: 10.0,
            guided_timeout_s: 3.0,
            gcs_system_id: 255,
            failsafe: FailsafeParams::default(),
            geofence: GeofenceParams::default(),
            feasibility: FeasibilityParams::default(),
            vertical: VerticalParams::default(),
            circle: CircleParams::default(),
            follow: FollowParams::default(),
            rally: RallyParams::default(),
        }
    }
}

/// `[failsafe]`: thresholds and the action each cause takes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FailsafeParams {
    /// Data link lost after this long without a heartbeat or MANUAL_CONTROL from the ground
    /// station `gcs_system_id` names (s; ArduCopter's `FS_GCS_TIMEOUT`, 5 s); armed only once
    /// it was heard, so a scripted flight without a ground station does not trip it. Other
    /// systems and the RC receiver never hold it off.
    pub link_timeout_s: f64,
    pub link_action: FailsafeAction,
    /// Battery share below which `battery_low_action` fires.
    pub battery_low: f64,
    pub battery_low_action: FailsafeAction,
    /// Battery share below which `battery_critical_action` fires.
    pub battery_critical: f64,
    pub battery_critical_action: FailsafeAction,
    /// Pack voltage below which, held for `battery_volt_timer_s`, `battery_low_action` fires
    /// too (V; 0 off) — ArduPilot's `BATT_LOW_VOLT`: a failing cell or connector shows in the
    /// voltage long before the charge counted says so.
    pub battery_low_volt: f64,
    /// As `battery_low_volt`, for `battery_critical_action` (ArduPilot's `BATT_CRT_VOLT`).
    pub battery_critical_volt: f64,
    /// How long the voltage must stay below a threshold (s), so that the sag of a climb at
    /// full power does not trip it (ArduPilot's `BATT_LOW_TIMER`, 10 s).
    pub battery_volt_timer_s: f64,
    pub geofence_action: FailsafeAction,
    pub estimator_action: FailsafeAction,
    pub critical_actor_action: FailsafeAction,
    /// No fresh navigation state (none newer than `nav_timeout_s`) for this long (s) lands.
    /// Counted net of brief returns (`NetHeldFor`). Until then the controller flies blind
    /// (level, a little below hover) and the mode stands, so a thread of a non-realtime host
    /// that misses a few periods (the flight side of a Zenoh split on a loaded host had its
    /// loop wait up to 95 ms) does not end a mission. PX4 waits `COM_POS_FS_DELAY` (1 s) of
    /// failed position checks before its failsafe acts.
    pub nav_stale_s: f64,
    /// The RC receiver is lost after this long without sticks (s; ArduPilot's `RC_FS_TIMEOUT`,
    /// 1 s; PX4's `COM_RC_LOSS_T` 0.5 s): while it is fresh it wins over MAVLink sticks, and
    /// its loss while a mode is flown from sticks fires `manual_action`, whatever a ground
    /// station's sticks do (`pilot_input`).
    pub manual_timeout_s: f64,
    /// A ground station's MANUAL_CONTROL older than this flies nothing (s; ArduPilot's
    /// `RC_OVERRIDE_TIME`, 3 s). With no receiver ever heard, this timing out while a mode is
    /// flown from sticks fires `manual_action`.
    pub mavlink_sticks_timeout_s: f64,
    /// What losing the sticks does (ArduPilot `FS_THR_ENABLE` = RTL, PX4 `NAV_RCL_ACT` = Return).
    pub manual_action: FailsafeAction,
    /// `[failsafe.motor_failure]`: the ESC-telemetry check (PX4's `FD_ACT_EN`,
    /// `FD_ACT_MOT_THR`, `FD_ACT_MOT_TOUT`); idle where no ESC telemetry is routed.
    pub motor_failure: MotorFailureParams,
    /// What a failed motor does when the others cannot hold every axis (a quad), PX4's
    /// `COM_ACT_FAIL_ACT` (its default is a warning; ours lands, as a spinning quad should).
    /// With four or more left (hexa, octo) the mixer flies on without it and the commander
    /// only reports it, as PX4 with `CA_FAILURE_MODE = 1`.
    pub motor_failure_action: FailsafeAction,
    /// Once the avoider is in the loop, no fresh correction for this long (s) fires
    /// `avoidance_action`. Until then a stale stream holds the leg (the commander's stale hold,
    /// as PX4's collision prevention allows no motion where it has no data, `CP_GO_NO_DATA` 0),
    /// and a stream back within it resumes the mission; past it the data is taken as gone.
    pub avoidance_lost_s: f64,
    /// What losing the avoider's data does: LAND, straight down where the vehicle holds (it
    /// flew there, and the forward camera never saw what lies on a way home).
    pub avoidance_action: FailsafeAction,
}

impl Default for FailsafeParams {
    fn default() -> FailsafeParams {
        FailsafeParams {
            link_timeout_s: 5.0,
            link_action: FailsafeAction::ReturnToLaunch,
            battery_low: 0.25,
            battery_low_action: FailsafeAction::ReturnToLaunch,
            battery_critical: 0.10,
            battery_critical_action: FailsafeAction::Land,
            battery_low_volt: 0.0,
            battery_critical_volt: 0.0,
            battery_volt_timer_s: 10.0,
            geofence_action: FailsafeAction::ReturnToLaunch,
            estimator_action: FailsafeAction::Land,
            critical_actor_action: FailsafeAction::Land,
            nav_stale_s: 1.0,
            manual_timeout_s: 1.0,
            mavlink_sticks_timeout_s: 3.0,
            manual_action: FailsafeAction::ReturnToLaunch,
            motor_failure: MotorFailureParams::default(),
            motor_failure_action: FailsafeAction::Land,
            avoidance_lost_s: 10.0,
            avoidance_action: FailsafeAction::Land,
        }
    }
}

impl FailsafeParams {
    /// Checks every action: each live one must have a code in its parameter's numbering
    /// (`failsafe_actions`), so the file and the ground station agree, and none may disarm — a
    /// failsafe ends in a controlled state, never with the motors stopped in the air.
    fn validate_actions(&self) -> Result<(), InvalidParam> {
        let live = [
            ("failsafe.link_action", self.link_action, &failsafe_actions::GCS),
            ("failsafe.manual_action", self.manual_action, &failsafe_actions::STICKS),
            ("failsafe.battery_low_action", self.battery_low_action, &failsafe_actions::BATTERY_LOW),
            (
                "failsafe.battery_critical_action",
                self.battery_critical_action,
                &failsafe_actions::BATTERY_CRITICAL,
            ),
            ("failsafe.estimator_action", self.estimator_action, &failsafe_actions::ESTIMATOR),
            ("failsafe.geofence_action", self.geofence_action, &failsafe_actions::FENCE),
            ("failsafe.motor_failure_action", self.motor_failure_action, &failsafe_actions::MOTOR),
        ];
        for (name, action, codes) in live {
            if codes.code(action).is_none() {
                return Err(InvalidParam::new(name, codes.why_not_action(action)));
            }
        }
        for (name, action) in [
            ("failsafe.critical_actor_action", self.critical_actor_action),
            ("failsafe.avoidance_action", self.avoidance_action),
        ] {
            if action == FailsafeAction::Disarm {
                return Err(InvalidParam::new(
                    name,
                    "a failsafe may not disarm in the air: choose land or hold",
                ));
            }
        }
        Ok(())
    }
}

/// `[geofence]`: the vehicle's own fences (ArduCopter's `FENCE_*` parameters, the defaults a
/// ground station's PARAM_SET changes live): a cylinder around home, a floor, and an optional
/// inclusion polygon beside the zones a ground station uploads.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GeofenceParams {
    /// The fence is on at boot (`FENCE_ENABLE`; MAV_CMD_DO_FENCE_ENABLE switches it after).
    pub enabled: bool,
    /// The fences enforced, ArduCopter's `FENCE_TYPE` bits: 1 ceiling, 2 circle, 4 polygons
    /// (configured and uploaded), 8 floor. ArduCopter's default 7.
    pub types: u8,
    /// Largest horizontal distance from home (m; `FENCE_RADIUS`).
    pub max_radius_m: f64,
    /// Largest height above home (m; `FENCE_ALT_MAX`).
    pub max_altitude_m: f64,
    /// Least height above home once climbed above it (m; `FENCE_ALT_MIN`, ArduCopter's -10).
    pub min_altitude_m: f64,
    /// Distance to keep from the fences (m; `FENCE_MARGIN`, ArduCopter's 2): the pre-arm checks
    /// want the circle and the altitude band wider than it.
    pub margin_m: f64,
    /// Inclusion polygon as `[lat_deg, lon_deg]` vertices; empty for none.
    pub polygon: Vec<[f64; 2]>,
    /// `FENCE_TOTAL`: not configured, but what the uploaded fence makes it
    /// (`geofence::fence_total`); a ground station reads it, and may set it only to itself.
    #[serde(skip)]
    pub total: u16,
}

impl Default for GeofenceParams {
    fn default() -> GeofenceParams {
        GeofenceParams {
            enabled: true,
            types: 7,
            max_radius_m: 300.0,
            max_altitude_m: 120.0,
            min_altitude_m: -10.0,
            margin_m: 2.0,
            polygon: Vec::new(),
            total: 0,
        }
    }
}

/// `[feasibility]`: what a mission or a GUIDED target may ask (see `feasibility`), checked on
/// upload, at the start of AUTO and for every target, whether or not the geofence is on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FeasibilityParams {
    /// Least height above home of a waypoint, take-off item or GUIDED target (m); landing points
    /// are exempt. PX4 refuses waypoints below home; 2 m keeps a mistyped 0 off the ground.
    pub min_height_m: f64,
    /// Largest horizontal distance from home, and height above it, of any point flown to (m):
    /// a bound that holds with the geofence off.
    pub max_distance_m: f64,
    /// Largest horizontal distance from the vehicle to a mission's first point (m), PX4's
    /// `MIS_DIST_1WP` (900 m): a plan made for another field is caught before take-off.
    pub first_distance_m: f64,
    /// Largest GUIDED velocity target (m/s), PX4's `MPC_XY_VEL_MAX` order (12 m/s).
    pub max_velocity_m_s: f64,
}

impl Default for FeasibilityParams {
    fn default() -> FeasibilityParams {
        FeasibilityParams {
            min_height_m: 2.0,
            max_distance_m: 1000.0,
            first_distance_m: 900.0,
            max_velocity_m_s: 12.0,
        }
    }
}

impl CommanderParams {
    /// Checks every field; the error names the first offending one.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        within("hover_thrust", self.hover_thrust, 0.05, 0.9)?;
        within("max_tilt_deg", self.max_tilt_deg, 1.0, 60.0)?;
        for (name, v) in [
            ("acro_rate_deg_s", self.acro_rate_deg_s),
            ("yaw_rate_deg_s", self.yaw_rate_deg_s),
            ("stick_climb_m_s", self.stick_climb_m_s),
            ("stick_speed_m_s", self.stick_speed_m_s),
            ("takeoff_altitude_m", self.takeoff_altitude_m),
            ("rtl_altitude_m", self.rtl_altitude_m),
            ("rtl_speed_m_s", self.rtl_speed_m_s),
            ("land_fast_m_s", self.land_fast_m_s),
            ("land_slow_m_s", self.land_slow_m_s),
            ("land_slow_height_m", self.land_slow_height_m),
            ("land_detect_s", self.land_detect_s),
            ("flip_min_height_m", self.flip_min_height_m),
            ("nav_timeout_s", self.nav_timeout_s),
            ("setpoint_rate_hz", self.setpoint_rate_hz),
            ("status_rate_hz", self.status_rate_hz),
            ("avoidance_timeout_s", self.avoidance_timeout_s),
            ("guided_speed_m_s", self.guided_speed_m_s),
            ("guided_timeout_s", self.guided_timeout_s),
            ("failsafe.link_timeout_s", self.failsafe.link_timeout_s),
            ("failsafe.manual_timeout_s", self.failsafe.manual_timeout_s),
            ("failsafe.mavlink_sticks_timeout_s", self.failsafe.mavlink_sticks_timeout_s),
            ("failsafe.avoidance_lost_s", self.failsafe.avoidance_lost_s),
            ("feasibility.max_distance_m", self.feasibility.max_distance_m),
            ("feasibility.first_distance_m", self.feasibility.first_distance_m),
            ("feasibility.max_velocity_m_s", self.feasibility.max_velocity_m_s),
            ("geofence.max_radius_m", self.geofence.max_radius_m),
            ("geofence.max_altitude_m", self.geofence.max_altitude_m),
        ] {
            positive(name, v)?;
        }
        within("rtl_loiter_s", self.rtl_loiter_s, 0.0, 600.0)?;
        if self.gcs_system_id == 0 {
            return Err(InvalidParam::new("gcs_system_id", "0 is broadcast, not a system: 1..=255"));
        }
        within("disarm_delay_s", self.disarm_delay_s, 0.0, 127.0)?;
        within("feasibility.min_height_m", self.feasibility.min_height_m, -100.0, 100.0)?;
        self.vertical.validate()?;
        self.circle.validate()?;
        self.follow.validate()?;
        within("rally.limit_km", self.rally.limit_km, 0.0, 100.0)?;
        within("throttle_deadband", self.throttle_deadband, 0.0, 0.5)?;
        within("failsafe.battery_low", self.failsafe.battery_low, 0.0, 1.0)?;
        within("failsafe.battery_critical", self.failsafe.battery_critical, 0.0, self.failsafe.battery_low)?;
        within("failsafe.battery_low_volt", self.failsafe.battery_low_volt, 0.0, 100.0)?;
        within("failsafe.battery_critical_volt", self.failsafe.battery_critical_volt, 0.0, 100.0)?;
        if self.failsafe.battery_critical_volt > 0.0
            && self.failsafe.battery_critical_volt >= self.failsafe.battery_low_volt
        {
            return Err(InvalidParam::new(
                "failsafe.battery_critical_volt",
                "must lie below failsafe.battery_low_volt (or be 0, off)",
            ));
        }
        within("failsafe.battery_volt_timer_s", self.failsafe.battery_volt_timer_s, 0.0, 120.0)?;
        within("failsafe.nav_stale_s", self.failsafe.nav_stale_s, 0.0, 10.0)?;
        self.failsafe.validate_actions()?;
        MotorFailureDetector::new(self.failsafe.motor_failure)
            .map_err(|e| InvalidParam::new("failsafe.motor_failure", e.to_string()))?;
        if self.geofence.types > 15 {
            return Err(InvalidParam::new("geofence.types", "FENCE_TYPE bits are 1, 2, 4 and 8: at most 15"));
        }
        within("geofence.min_altitude_m", self.geofence.min_altitude_m, -100.0, 100.0)?;
        within("geofence.margin_m", self.geofence.margin_m, 0.0, 100.0)?;
        let polygon = &self.geofence.polygon;
        if !polygon.is_empty() && polygon.len() < 3 {
            return Err(InvalidParam::new("geofence.polygon", "needs at least 3 vertices"));
        }
        if polygon.iter().any(|[lat, lon]| !(lat.abs() <= 90.0 && lon.abs() <= 180.0)) {
            return Err(InvalidParam::new("geofence.polygon", "vertex outside latitude/longitude range"));
        }
        Ok(())
    }
}
