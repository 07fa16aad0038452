//! The commander's live parameters: every tunable field of [`CommanderParams`] a ground station
//! may change in flight, declared once here with its MAVLink name, range and unit. The actor
//! publishes this table to the link (`param_decl`) and applies `ParamSet`s against it. Names
//! follow ArduPilot's where one exists, with the unit spelled out (`RTL_ALT_M`), or exactly
//! ArduCopter's where ground station tools set them by name (the `FENCE_*` family), so
//! QGroundControl and MAVProxy users recognise them. Ranges are what a small multirotor can
//! sensibly fly; the whole struct is validated again after each change (e.g. the critical
//! battery share must stay below the low one), and a refused change keeps the old value. The
//! failsafe actions are enumerations in ArduCopter's (and for a motor PX4's) numbering
//! (`failsafe_actions`): only their codes are taken.

use kestrel_proto::messages::FailsafeAction;
use kestrel_proto::param_def::{self, ParamChange, ParamDef, ParamRefused, WhileArmed};

use super::failsafe_actions::{self, ActionCodes};
use super::params::CommanderParams;

/// Every live commander parameter.
pub const LIVE_PARAMS: &[ParamDef<CommanderParams>] = &[
    ParamDef {
        name: "RTL_ALT_M",
        unit: "m",
        min: 2.0,
        max: 120.0,
        description: "RTL climbs to at least this height above home",
        while_armed: WhileArmed::Tunable,
        get: |p| p.rtl_altitude_m,
        set: |p, v| p.rtl_altitude_m = v,
    },
    ParamDef {
        name: "RTL_SPEED_M_S",
        unit: "m/s",
        min: 0.5,
        max: 15.0,
        description: "RTL horizontal return speed",
        while_armed: WhileArmed::Tunable,
        get: |p| p.rtl_speed_m_s,
        set: |p, v| p.rtl_speed_m_s = v,
    },
    ParamDef {
        name: "RTL_LOIT_TIME_S",
        unit: "s",
        min: 0.0,
        max: 600.0,
        description: "RTL loiter above home before landing",
        while_armed: WhileArmed::Tunable,
        get: |p| p.rtl_loiter_s,
        set: |p, v| p.rtl_loiter_s = v,
    },
    ParamDef {
        name: "RALLY_LIMIT_KM",
        unit: "km",
        min: 0.0,
        max: 100.0,
        description: "RTL flies to the nearest rally point only within this distance; 0 = any",
        while_armed: WhileArmed::Tunable,
        get: |p| p.rally.limit_km,
        set: |p, v| p.rally.limit_km = v,
    },
    ParamDef {
        name: "RALLY_INCL_HOME",
        unit: "",
        min: 0.0,
        max: 1.0,
        description: "Home counts as a rally point: 0 no, 1 yes",
        while_armed: WhileArmed::Tunable,
        get: |p| f64::from(u8::from(p.rally.include_home)),
        set: |p, v| p.rally.include_home = v != 0.0,
    },
    ParamDef {
        name: "TKOFF_ALT_M",
        unit: "m",
        min: 1.0,
        max: 120.0,
        description: "Take-off height above home",
        while_armed: WhileArmed::Tunable,
        get: |p| p.takeoff_altitude_m,
        set: |p, v| p.takeoff_altitude_m = v,
    },
    ParamDef {
        name: "AVOID_MARGIN_M",
        unit: "m",
        min: 0.2,
        max: 10.0,
        description: "No climb within this of what the upward rangefinder sees",
        while_armed: WhileArmed::Tunable,
        get: |p| p.vertical.margin_m,
        set: |p, v| p.vertical.margin_m = v,
    },
    ParamDef {
        name: "LAND_OBS_HGT_M",
        unit: "m",
        min: 0.0,
        max: 50.0,
        description: "A surface under a landing more than this above home is an obstacle's top (0 = off)",
        while_armed: WhileArmed::Tunable,
        get: |p| p.vertical.obstacle_below_m,
        set: |p, v| p.vertical.obstacle_below_m = v,
    },
    ParamDef {
        name: "WPNAV_SPEED_M_S",
        unit: "m/s",
        min: 0.5,
        max: 15.0,
        description: "GUIDED target speed while the avoider is in the loop",
        while_armed: WhileArmed::Tunable,
        get: |p| p.guided_speed_m_s,
        set: |p, v| p.guided_speed_m_s = v,
    },
    ParamDef {
        name: "CIRCLE_RADIUS_M",
        unit: "m",
        min: 0.0,
        max: 1000.0,
        description: "CIRCLE's radius when the mode is entered (ArduCopter CIRCLE_RADIUS, in m)",
        while_armed: WhileArmed::Tunable,
        get: |p| p.circle.radius_m,
        set: |p, v| p.circle.radius_m = v,
    },
    ParamDef {
        name: "CIRCLE_RATE_DEGS",
        unit: "deg/s",
        min: -90.0,
        max: 90.0,
        description: "CIRCLE's turn rate, positive clockwise (ArduCopter CIRCLE_RATE)",
        while_armed: WhileArmed::Tunable,
        get: |p| p.circle.rate_deg_s,
        set: |p, v| p.circle.rate_deg_s = v,
    },
    ParamDef {
        name: "LAND_SPEED_M_S",
        unit: "m/s",
        min: 0.1,
        max: 5.0,
        description: "Landing descent rate near the ground",
        while_armed: WhileArmed::Tunable,
        get: |p| p.land_slow_m_s,
        set: |p, v| p.land_slow_m_s = v,
    },
    ParamDef {
        name: "LAND_SPD_HI_M_S",
        unit: "m/s",
        min: 0.2,
        max: 5.0,
        description: "Landing descent rate above LAND_SLOW_ALT_M",
        while_armed: WhileArmed::Tunable,
        get: |p| p.land_fast_m_s,
        set: |p, v| p.land_fast_m_s = v,
    },
    ParamDef {
        name: "LAND_SLOW_ALT_M",
        unit: "m",
        min: 0.5,
        max: 50.0,
        description: "Height above home below which the landing slows",
        while_armed: WhileArmed::Tunable,
        get: |p| p.land_slow_height_m,
        set: |p, v| p.land_slow_height_m = v,
    },
    ParamDef {
        name: "ANGLE_MAX_DEG",
        unit: "deg",
        min: 5.0,
        max: 60.0,
        description: "Tilt at full stick in STABILIZE/ALT_HOLD",
        while_armed: WhileArmed::Tunable,
        get: |p| p.max_tilt_deg,
        set: |p, v| p.max_tilt_deg = v,
    },
    ParamDef {
        name: "PILOT_SPEED_M_S",
        unit: "m/s",
        min: 0.5,
        max: 15.0,
        description: "Horizontal speed at full stick in POSHOLD",
        while_armed: WhileArmed::Tunable,
        get: |p| p.stick_speed_m_s,
        set: |p, v| p.stick_speed_m_s = v,
    },
    ParamDef {
        name: "PILOT_SPD_UP_M_S",
        unit: "m/s",
        min: 0.2,
        max: 8.0,
        description: "Climb rate at full throttle in ALT_HOLD/POSHOLD",
        while_armed: WhileArmed::Tunable,
        get: |p| p.stick_climb_m_s,
        set: |p, v| p.stick_climb_m_s = v,
    },
    ParamDef {
        name: "DISARM_DELAY",
        unit: "s",
        min: 0.0,
        max: 127.0,
        description: "Armed on the ground this long without taking off disarms; 0 = never",
        while_armed: WhileArmed::Tunable,
        get: |p| p.disarm_delay_s,
        set: |p, v| p.disarm_delay_s = v,
    },
    ParamDef {
        name: "GUID_TIMEOUT_S",
        unit: "s",
        min: 0.1,
        max: 30.0,
        description: "A GUIDED velocity target not repeated within this time is dropped: hold",
        while_armed: WhileArmed::Tunable,
        get: |p| p.guided_timeout_s,
        set: |p, v| p.guided_timeout_s = v,
    },
    ParamDef {
        name: "MAV_GCS_SYSID",
        unit: "",
        min: 1.0,
        max: 255.0,
        description: "The ground station in control: its heartbeats and sticks count, others' not",
        while_armed: WhileArmed::Tunable,
        get: |p| f64::from(p.gcs_system_id),
        // `apply` takes whole numbers only, and the range is 1..=255.
        set: |p, v| p.gcs_system_id = v as u8,
    },
    ParamDef {
        name: "RC_OVERRIDE_TIME",
        unit: "s",
        min: 0.2,
        max: 30.0,
        description: "A ground station's MANUAL_CONTROL older than this flies nothing",
        while_armed: WhileArmed::Tunable,
        get: |p| p.failsafe.mavlink_sticks_timeout_s,
        set: |p, v| p.failsafe.mavlink_sticks_timeout_s = v,
    },
    ParamDef {
        name: "FS_GCS_TIMEOUT_S",
        unit: "s",
        min: 1.0,
        max: 60.0,
        description: "Data link lost after this long without MAV_GCS_SYSID's heartbeat or sticks",
        while_armed: WhileArmed::Tunable,
        get: |p| p.failsafe.link_timeout_s,
        set: |p, v| p.failsafe.link_timeout_s = v,
    },
    ParamDef {
        name: "FS_NAV_TIMEOUT_S",
        unit: "s",
        min: 0.0,
        max: 10.0,
        description: "No fresh navigation state for this long lands (PX4's COM_POS_FS_DELAY)",
        while_armed: WhileArmed::Tunable,
        get: |p| p.failsafe.nav_stale_s,
        set: |p, v| p.failsafe.nav_stale_s = v,
    },
    ParamDef {
        name: "FS_RC_TIMEOUT_S",
        unit: "s",
        min: 0.2,
        max: 5.0,
        description: "RC receiver lost after this long: MAVLink sticks fly, RC-loss failsafe",
        while_armed: WhileArmed::Tunable,
        get: |p| p.failsafe.manual_timeout_s,
        set: |p, v| p.failsafe.manual_timeout_s = v,
    },
    ParamDef {
        name: "MIS_MIN_ALT_M",
        unit: "m",
        min: -100.0,
        max: 100.0,
        description: "Least height above home of a waypoint or GUIDED target",
        while_armed: WhileArmed::Tunable,
        get: |p| p.feasibility.min_height_m,
        set: |p, v| p.feasibility.min_height_m = v,
    },
    ParamDef {
        name: "MIS_MAX_DIST_M",
        unit: "m",
        min: 10.0,
        max: 50000.0,
        description: "Largest distance from home (and height) of a point flown to",
        while_armed: WhileArmed::Tunable,
        get: |p| p.feasibility.max_distance_m,
        set: |p, v| p.feasibility.max_distance_m = v,
    },
    ParamDef {
        name: "MIS_DIST_1WP_M",
        unit: "m",
        min: 10.0,
        max: 50000.0,
        description: "Largest distance from the vehicle to a mission's first point",
        while_armed: WhileArmed::Tunable,
        get: |p| p.feasibility.first_distance_m,
        set: |p, v| p.feasibility.first_distance_m = v,
    },
    ParamDef {
        name: "BATT_LOW_FRAC",
        unit: "",
        min: 0.1,
        max: 0.9,
        description: "Battery share below which the low-battery failsafe acts",
        while_armed: WhileArmed::Tunable,
        get: |p| p.failsafe.battery_low,
        set: |p, v| p.failsafe.battery_low = v,
    },
    ParamDef {
        name: "BATT_CRT_FRAC",
        unit: "",
        min: 0.0,
        max: 0.8,
        description: "Battery share below which the critical-battery failsafe acts",
        while_armed: WhileArmed::Tunable,
        get: |p| p.failsafe.battery_critical,
        set: |p, v| p.failsafe.battery_critical = v,
    },
    ParamDef {
        name: "BATT_LOW_VOLT",
        unit: "V",
        min: 0.0,
        max: 100.0,
        description: "Pack voltage below which (for BATT_LOW_TIMER) the low-battery failsafe acts; 0 off",
        while_armed: WhileArmed::Tunable,
        get: |p| p.failsafe.battery_low_volt,
        set: |p, v| p.failsafe.battery_low_volt = v,
    },
    ParamDef {
        name: "BATT_CRT_VOLT",
        unit: "V",
        min: 0.0,
        max: 100.0,
        description: "Pack voltage below which (for BATT_LOW_TIMER) the critical failsafe acts; 0 off",
        while_armed: WhileArmed::Tunable,
        get: |p| p.failsafe.battery_critical_volt,
        set: |p, v| p.failsafe.battery_critical_volt = v,
    },
    ParamDef {
        name: "BATT_LOW_TIMER",
        unit: "s",
        min: 0.0,
        max: 120.0,
        description: "How long the voltage must stay below BATT_LOW_VOLT or BATT_CRT_VOLT",
        while_armed: WhileArmed::Tunable,
        get: |p| p.failsafe.battery_volt_timer_s,
        set: |p, v| p.failsafe.battery_volt_timer_s = v,
    },
    ParamDef {
        name: "FENCE_ENABLE",
        unit: "",
        min: 0.0,
        max: 1.0,
        description: "Geofence on (1) or off (0); MAV_CMD_DO_FENCE_ENABLE switches it too",
        while_armed: WhileArmed::Tunable,
        get: |p| f64::from(u8::from(p.geofence.enabled)),
        set: |p, v| p.geofence.enabled = v == 1.0,
    },
    ParamDef {
        name: "FENCE_TYPE",
        unit: "",
        min: 0.0,
        max: 15.0,
        description: "Geofence kinds enforced, bits: 1 max altitude, 2 circle, 4 polygons, 8 min altitude",
        while_armed: WhileArmed::Tunable,
        get: |p| f64::from(p.geofence.types),
        // The range is checked first; a fraction is not a bit mask.
        set: |p, v| p.geofence.types = if v.fract() == 0.0 { v as u8 } else { u8::MAX },
    },
    ParamDef {
        name: "FENCE_RADIUS",
        unit: "m",
        min: 10.0,
        max: 10000.0,
        description: "Geofence: largest horizontal distance from home",
        while_armed: WhileArmed::Tunable,
        get: |p| p.geofence.max_radius_m,
        set: |p, v| p.geofence.max_radius_m = v,
    },
    ParamDef {
        name: "FENCE_ALT_MAX",
        unit: "m",
        min: 5.0,
        max: 500.0,
        description: "Geofence: largest height above home",
        while_armed: WhileArmed::Tunable,
        get: |p| p.geofence.max_altitude_m,
        set: |p, v| p.geofence.max_altitude_m = v,
    },
    ParamDef {
        name: "FENCE_ALT_MIN",
        unit: "m",
        min: -100.0,
        max: 100.0,
        description: "Geofence: least height above home, once climbed above it",
        while_armed: WhileArmed::Tunable,
        get: |p| p.geofence.min_altitude_m,
        set: |p, v| p.geofence.min_altitude_m = v,
    },
    ParamDef {
        name: "FENCE_MARGIN",
        unit: "m",
        min: 0.0,
        max: 100.0,
        description: "Geofence: distance to keep from the fences (pre-arm: circle and altitude band wider)",
        while_armed: WhileArmed::Tunable,
        get: |p| p.geofence.margin_m,
        set: |p, v| p.geofence.margin_m = v,
    },
    ParamDef {
        name: "FENCE_TOTAL",
        unit: "",
        // The range the link checks is the value itself (`Commander::param_decl`): the count
        // follows the uploaded fence, and with no FENCE_POINT protocol another count would
        // mean nothing.
        min: 0.0,
        max: 65535.0,
        description: "Count of stored fence items (vertices and circles, +2 when at least 3); set by a MISSION_TYPE_FENCE upload",
        while_armed: WhileArmed::Tunable,
        get: |p| f64::from(p.geofence.total),
        set: |_, _| {},
    },
    ParamDef {
        name: "FD_ACT_EN",
        unit: "",
        min: 0.0,
        max: 1.0,
        description: "Motor-failure detection from ESC telemetry: 1 on, 0 off",
        while_armed: WhileArmed::Tunable,
        get: |p| f64::from(u8::from(p.failsafe.motor_failure.enabled)),
        set: |p, v| p.failsafe.motor_failure.enabled = v == 1.0,
    },
    ParamDef {
        name: "FD_ACT_MOT_THR",
        unit: "",
        min: 0.0,
        max: 0.99,
        description: "Motor command (0..1) above which a motor must produce thrust",
        while_armed: WhileArmed::Tunable,
        get: |p| f64::from(p.failsafe.motor_failure.throttle_threshold),
        set: |p, v| p.failsafe.motor_failure.throttle_threshold = v as f32,
    },
    ParamDef {
        name: "FD_ACT_MOT_TOUT",
        unit: "s",
        min: 0.01,
        max: 10.0,
        description: "How long a motor's thrust must fall short before it counts as failed",
        while_armed: WhileArmed::Tunable,
        get: |p| f64::from(p.failsafe.motor_failure.timeout_s),
        set: |p, v| p.failsafe.motor_failure.timeout_s = v as f32,
    },
    ParamDef {
        name: "FS_GCS_ENABLE",
        unit: "",
        min: 0.0,
        max: 7.0,
        description: "Ground station lost: 0 report, 1 RTL, 5 land, 7 brake and hold",
        while_armed: WhileArmed::Tunable,
        get: |p| action_code(&failsafe_actions::GCS, p.failsafe.link_action),
        set: |p, v| set_action(&failsafe_actions::GCS, &mut p.failsafe.link_action, v),
    },
    ParamDef {
        name: "FS_THR_ENABLE",
        unit: "",
        min: 0.0,
        max: 7.0,
        description: "Sticks lost: 0 report, 1 RTL, 3 land, 7 brake and hold",
        while_armed: WhileArmed::Tunable,
        get: |p| action_code(&failsafe_actions::STICKS, p.failsafe.manual_action),
        set: |p, v| set_action(&failsafe_actions::STICKS, &mut p.failsafe.manual_action, v),
    },
    ParamDef {
        name: "BATT_FS_LOW_ACT",
        unit: "",
        min: 0.0,
        max: 7.0,
        description: "Battery low: 0 report, 1 land, 2 RTL, 7 brake and hold",
        while_armed: WhileArmed::Tunable,
        get: |p| action_code(&failsafe_actions::BATTERY_LOW, p.failsafe.battery_low_action),
        set: |p, v| set_action(&failsafe_actions::BATTERY_LOW, &mut p.failsafe.battery_low_action, v),
    },
    ParamDef {
        name: "BATT_FS_CRT_ACT",
        unit: "",
        min: 0.0,
        max: 7.0,
        description: "Battery critical: 0 report, 1 land, 2 RTL, 7 brake and hold",
        while_armed: WhileArmed::Tunable,
        get: |p| action_code(&failsafe_actions::BATTERY_CRITICAL, p.failsafe.battery_critical_action),
        set: |p, v| {
            set_action(&failsafe_actions::BATTERY_CRITICAL, &mut p.failsafe.battery_critical_action, v)
        },
    },
    ParamDef {
        name: "FS_EKF_ACTION",
        unit: "",
        min: 1.0,
        max: 2.0,
        description: "Estimate lost: 1 land, 2 hold altitude",
        while_armed: WhileArmed::Tunable,
        get: |p| action_code(&failsafe_actions::ESTIMATOR, p.failsafe.estimator_action),
        set: |p, v| set_action(&failsafe_actions::ESTIMATOR, &mut p.failsafe.estimator_action, v),
    },
    ParamDef {
        name: "FENCE_ACTION",
        unit: "",
        min: 0.0,
        max: 4.0,
        description: "Geofence breach: 0 report, 1 RTL or land, 2 land, 4 brake and hold",
        while_armed: WhileArmed::Tunable,
        get: |p| action_code(&failsafe_actions::FENCE, p.failsafe.geofence_action),
        set: |p, v| set_action(&failsafe_actions::FENCE, &mut p.failsafe.geofence_action, v),
    },
    ParamDef {
        name: "COM_ACT_FAIL_ACT",
        unit: "",
        min: 0.0,
        max: 3.0,
        description: "Motor failed (quad): 0 warn, 1 hold, 2 land, 3 return",
        while_armed: WhileArmed::Tunable,
        get: |p| action_code(&failsafe_actions::MOTOR, p.failsafe.motor_failure_action),
        set: |p, v| set_action(&failsafe_actions::MOTOR, &mut p.failsafe.motor_failure_action, v),
    },
];

/// The live parameters that are switches: exactly 0 (off) or 1 (on); a value between answers
/// neither.
const SWITCHES: [&str; 2] = ["FD_ACT_EN", "RALLY_INCL_HOME"];

/// Parameters that are whole numbers (a system id).
const WHOLE: [&str; 1] = ["MAV_GCS_SYSID"];

/// A failsafe action's code (NaN, which no declaration passes, if it has none: `validate`
/// refuses such an action before it can be declared).
fn action_code(codes: &ActionCodes, action: FailsafeAction) -> f64 {
    codes.code(action).map_or(f64::NAN, f64::from)
}

/// Sets the action `value` codes for; `apply` has refused every value without one.
fn set_action(codes: &ActionCodes, action: &mut FailsafeAction, value: f64) {
    if let Some(coded) = codes.action(value) {
        *action = coded;
    }
}

/// Sets the live parameter `name` to `value` in `params`, keeping the old value when it is out
/// of range, a switch is set to anything but 0 or 1, an action to anything but one of its
/// codes, or the result would not validate. A changed action applies from the next time its
/// cause fires; one already fired keeps the action it fired with.
pub fn apply(params: &mut CommanderParams, name: &str, value: f64) -> Result<ParamChange, ParamRefused> {
    if SWITCHES.contains(&name) && value != 0.0 && value != 1.0 {
        return Err(ParamRefused::Invalid {
            name: name.to_owned(),
            reason: format!("is a switch: 0 or 1, got {value}"),
        });
    }
    if WHOLE.contains(&name) && value.fract() != 0.0 {
        return Err(ParamRefused::Invalid {
            name: name.to_owned(),
            reason: format!("is a whole number, got {value}"),
        });
    }
    if let Some(codes) = failsafe_actions::named(name)
        && codes.action(value).is_none()
    {
        return Err(ParamRefused::Invalid { name: name.to_owned(), reason: codes.why_not(value) });
    }
    match param_def::apply(LIVE_PARAMS, params, name, value, CommanderParams::validate)? {
        // FOLLOW's `FOLL_*` live beside the mode (`follow`).
        ParamChange::NotMine => super::follow::apply_param(params, name, value),
        change => Ok(change),
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::Time;

    use super::*;

    #[test]
    fn a_switch_takes_exactly_0_or_1() {
        let mut params = CommanderParams::default();
        assert!(params.failsafe.motor_failure.enabled);
        for bad in [0.5, 0.999, f64::NAN] {
            assert!(
                matches!(apply(&mut params, "FD_ACT_EN", bad), Err(ParamRefused::Invalid { .. })),
                "{bad}"
            );
            assert!(params.failsafe.motor_failure.enabled, "kept after {bad}");
        }
        assert_eq!(apply(&mut params, "FD_ACT_EN", 0.0), Ok(ParamChange::Applied));
        assert!(!params.failsafe.motor_failure.enabled);
        assert_eq!(apply(&mut params, "FD_ACT_EN", 1.0), Ok(ParamChange::Applied));
        assert!(params.failsafe.motor_failure.enabled);
    }

    #[test]
    fn the_defaults_declare_a_valid_table() {
        param_def::declare(LIVE_PARAMS, &CommanderParams::default(), "commander", true, Time::ZERO)
            .check()
            .expect("every default inside its range, names unique and short");
    }

    #[test]
    fn a_live_change_applies_and_an_invalid_one_keeps_the_old_value() {
        let mut params = CommanderParams::default();
        assert_eq!(apply(&mut params, "RTL_ALT_M", 25.0), Ok(ParamChange::Applied));
        assert_eq!(params.rtl_altitude_m, 25.0);
        assert_eq!(apply(&mut params, "LAND_SPEED_M_S", 0.4), Ok(ParamChange::Applied));
        assert_eq!(params.land_slow_m_s, 0.4);
        assert_eq!(apply(&mut params, "SYSID_THISMAV", 3.0), Ok(ParamChange::NotMine));
        let before = params.clone();
        assert!(apply(&mut params, "RTL_ALT_M", f64::NAN).is_err());
        assert!(apply(&mut params, "BATT_LOW_FRAC", 7.0).is_err(), "a share above 1 is refused");
        assert!(
            matches!(apply(&mut params, "BATT_CRT_FRAC", 0.5), Err(ParamRefused::Invalid { .. })),
            "critical above low (0.25) fails the commander's own validation"
        );
        assert_eq!(params, before);
    }

    #[test]
    fn the_motor_failure_detector_is_tuned_live_under_px4_names() {
        let mut params = CommanderParams::default();
        assert_eq!(apply(&mut params, "FD_ACT_EN", 0.0), Ok(ParamChange::Applied));
        assert!(!params.failsafe.motor_failure.enabled);
        assert_eq!(apply(&mut params, "FD_ACT_MOT_TOUT", 0.25), Ok(ParamChange::Applied));
        assert_eq!(params.failsafe.motor_failure.timeout_s, 0.25);
        assert!(
            apply(&mut params, "FD_ACT_MOT_THR", 1.0).is_err(),
            "a threshold of full throttle never judges"
        );
        assert!(apply(&mut params, "FD_ACT_MOT_TOUT", f64::NAN).is_err());
    }

    #[test]
    fn failsafe_actions_take_exactly_their_codes_and_declare_their_range() {
        for codes in failsafe_actions::ALL {
            let def = LIVE_PARAMS.iter().find(|d| d.name == codes.name).expect("declared");
            assert_eq!((def.min, def.max), codes.bounds(), "{}: declared range", codes.name);
        }
        let mut params = CommanderParams::default();
        assert_eq!(params.failsafe.link_action, FailsafeAction::ReturnToLaunch);
        assert_eq!(apply(&mut params, "FS_GCS_ENABLE", 5.0), Ok(ParamChange::Applied));
        assert_eq!(params.failsafe.link_action, FailsafeAction::Land);
        assert_eq!(apply(&mut params, "FENCE_ACTION", 4.0), Ok(ParamChange::Applied));
        assert_eq!(params.failsafe.geofence_action, FailsafeAction::Hold);
        let before = params.clone();
        for (name, bad) in [
            ("FS_GCS_ENABLE", 3.0),
            ("FS_GCS_ENABLE", 5.5),
            ("FS_GCS_ENABLE", f64::NAN),
            ("BATT_FS_CRT_ACT", 5.0),
            ("FS_EKF_ACTION", 0.0),
            ("COM_ACT_FAIL_ACT", 4.0),
        ] {
            let refused = apply(&mut params, name, bad);
            assert!(matches!(refused, Err(ParamRefused::Invalid { .. })), "{name}={bad}: {refused:?}");
        }
        let why = apply(&mut params, "BATT_FS_CRT_ACT", 5.0).expect_err("terminate").to_string();
        assert!(why.contains("BATT_FS_CRT_ACT") && why.contains("Terminate"), "{why}");
        assert_eq!(params, before, "a refused action keeps the old one");
        let declared = param_def::declare(LIVE_PARAMS, &params, "commander", false, Time::ZERO);
        declared.check().expect("valid declaration");
        let value = |name: &str| declared.params.iter().find(|p| p.name == name).map(|p| p.value);
        assert_eq!(value("FS_GCS_ENABLE"), Some(5.0));
        assert_eq!(value("FENCE_ACTION"), Some(4.0));
        assert_eq!(value("FS_EKF_ACTION"), Some(1.0));
    }

    #[test]
    fn a_configured_action_without_a_code_or_one_that_disarms_is_refused() {
        let mut params = CommanderParams::default();
        params.failsafe.estimator_action = FailsafeAction::ReturnToLaunch;
        let why = params.validate().expect_err("no FS_EKF_ACTION code").to_string();
        assert!(why.contains("failsafe.estimator_action") && why.contains("FS_EKF_ACTION"), "{why}");
        for disarm in [
            |p: &mut CommanderParams| p.failsafe.battery_critical_action = FailsafeAction::Disarm,
            |p: &mut CommanderParams| p.failsafe.avoidance_action = FailsafeAction::Disarm,
        ] {
            let mut params = CommanderParams::default();
            disarm(&mut params);
            assert!(params.validate().is_err(), "{:?}", params.failsafe);
        }
    }
}
