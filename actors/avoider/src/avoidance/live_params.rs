//! The avoider's live parameters: every tunable of [`AvoiderParams`] but the rule base file and
//! the staleness timer's period (both fixed when the actor is built), declared once here with
//! `AVOID_*` names. The ranges bound each value; [`AvoiderParams::validate`] runs again on the
//! changed struct (the climb-exit share must stay at most the blocked share), and a refusal
//! keeps the old value.

use kestrel_proto::Time;
use kestrel_proto::messages::ParamDecl;
use kestrel_proto::param_def::{self, ParamChange, ParamDef, ParamRefused, WhileArmed};

use super::params::AvoiderParams;

/// Every live parameter of the avoider.
pub const LIVE_PARAMS: &[ParamDef<AvoiderParams>] = &[
    ParamDef {
        name: "AVOID_SPEED_MAX",
        unit: "m/s",
        min: 0.5,
        max: 20.0,
        description: "Vehicle speed that V_in = 1 stands for; a fuzzy output of 1 is a correction this fast",
        while_armed: WhileArmed::Tunable,
        get: |p| p.max_speed_m_s,
        set: |p, v| p.max_speed_m_s = v,
    },
    ParamDef {
        name: "AVOID_FILT_TAU_S",
        unit: "s",
        min: 0.0,
        max: 5.0,
        description: "Time constant of the low-pass on the correction (0: off)",
        while_armed: WhileArmed::Tunable,
        get: |p| p.filter_time_constant_s,
        set: |p, v| p.filter_time_constant_s = v,
    },
    ParamDef {
        name: "AVOID_BLOCKED",
        unit: "",
        min: 0.05,
        max: 1.0,
        description: "Near-pixel share from which a region is blocked",
        while_armed: WhileArmed::Tunable,
        get: |p| p.blocked_share,
        set: |p, v| p.blocked_share = v,
    },
    ParamDef {
        name: "AVOID_CLIMB_EXIT",
        unit: "",
        min: 0.0,
        max: 1.0,
        description: "Near-pixel share below which a blocked centre is clear again (at most AVOID_BLOCKED)",
        while_armed: WhileArmed::Tunable,
        get: |p| p.climb_exit_share,
        set: |p, v| p.climb_exit_share = v,
    },
    ParamDef {
        name: "AVOID_CLIMB_M_S",
        unit: "m/s",
        min: 0.1,
        max: 5.0,
        description: "Climb rate while every region is blocked",
        while_armed: WhileArmed::Tunable,
        get: |p| p.climb_speed_m_s,
        set: |p, v| p.climb_speed_m_s = v,
    },
    ParamDef {
        name: "AVOID_CLIMB_MRG",
        unit: "m",
        min: 0.0,
        max: 10.0,
        description: "Height climbed on after the centre has cleared",
        while_armed: WhileArmed::Tunable,
        get: |p| p.climb_margin_m,
        set: |p, v| p.climb_margin_m = v,
    },
    ParamDef {
        name: "AVOID_UNK_INVAL",
        unit: "",
        min: 0.05,
        max: 1.0,
        description: "Invalid-pixel share above which a region is unknown",
        while_armed: WhileArmed::Tunable,
        get: |p| p.unknown_invalid_share,
        set: |p, v| p.unknown_invalid_share = v,
    },
    ParamDef {
        name: "AVOID_UNK_SPEED",
        unit: "",
        min: 0.0,
        max: 1.0,
        description: "Share of the desired speed kept while the view ahead is unknown (0: stop)",
        while_armed: WhileArmed::Tunable,
        get: |p| p.unknown_speed_share,
        set: |p, v| p.unknown_speed_share = v,
    },
    ParamDef {
        name: "AVOID_UNK_RANGE",
        unit: "m",
        min: 0.0,
        max: 20.0,
        description: "Distance ahead vouched for while the centre is mostly invalid (speed cap)",
        while_armed: WhileArmed::Tunable,
        get: |p| p.unknown_range_m,
        set: |p, v| p.unknown_range_m = v,
    },
    ParamDef {
        name: "AVOID_GND_HGT",
        unit: "m",
        min: 1.0,
        max: 100.0,
        description: "Height above which the stereo cannot match the ground below the path",
        while_armed: WhileArmed::Tunable,
        get: |p| p.ground_match_height_m,
        set: |p, v| p.ground_match_height_m = v,
    },
    ParamDef {
        name: "AVOID_STOP_DIST",
        unit: "m",
        min: 0.0,
        max: 20.0,
        description: "The forward speed is capped to stop this far short of the nearest depth ahead",
        while_armed: WhileArmed::Tunable,
        get: |p| p.stop_distance_m,
        set: |p, v| p.stop_distance_m = v,
    },
    ParamDef {
        name: "AVOID_PATH_HWID",
        unit: "m",
        min: 0.0,
        max: 5.0,
        description: "Half width of the flight path: a sector return within it of the nose caps the forward speed",
        while_armed: WhileArmed::Tunable,
        get: |p| p.path_half_width_m,
        set: |p, v| p.path_half_width_m = v,
    },
    ParamDef {
        name: "AVOID_BRAKE_ACC",
        unit: "m/s^2",
        min: 0.5,
        max: 10.0,
        description: "Deceleration the forward-speed cap assumes",
        while_armed: WhileArmed::Tunable,
        get: |p| p.brake_decel_m_s2,
        set: |p, v| p.brake_decel_m_s2 = v,
    },
    ParamDef {
        name: "AVOID_REACT_S",
        unit: "s",
        min: 0.0,
        max: 2.0,
        description: "Delay the forward-speed cap allows for before braking starts",
        while_armed: WhileArmed::Tunable,
        get: |p| p.reaction_time_s,
        set: |p, v| p.reaction_time_s = v,
    },
    ParamDef {
        name: "AVOID_SIDE_M_S",
        unit: "m/s",
        min: 0.0,
        max: 5.0,
        description: "Sidestep speed when the path is blocked and the rule base gives no way (0: off)",
        while_armed: WhileArmed::Tunable,
        get: |p| p.sidestep_speed_m_s,
        set: |p, v| p.sidestep_speed_m_s = v,
    },
    ParamDef {
        name: "AVOID_SIDE_DIST",
        unit: "m",
        min: 0.0,
        max: 20.0,
        description: "A depth nearer than this straight ahead blocks the path even with few near pixels",
        while_armed: WhileArmed::Tunable,
        get: |p| p.sidestep_distance_m,
        set: |p, v| p.sidestep_distance_m = v,
    },
    ParamDef {
        name: "AVOID_SIDE_MAX",
        unit: "m",
        min: 0.5,
        max: 50.0,
        description: "A sidestep that has slid this far with the path still blocked climbs instead",
        while_armed: WhileArmed::Tunable,
        get: |p| p.sidestep_max_m,
        set: |p, v| p.sidestep_max_m = v,
    },
    ParamDef {
        name: "AVOID_MEM_TIME_S",
        unit: "s",
        min: 0.0,
        max: 120.0,
        description: "Obstacles seen are remembered this long, also out of view (0: no memory)",
        while_armed: WhileArmed::Tunable,
        get: |p| p.memory_time_s,
        set: |p, v| p.memory_time_s = v,
    },
    ParamDef {
        name: "AVOID_MEM_RANGE",
        unit: "m",
        min: 0.5,
        max: 20.0,
        description: "Obstacles up to this far are remembered",
        while_armed: WhileArmed::Tunable,
        get: |p| p.memory_range_m,
        set: |p, v| p.memory_range_m = v,
    },
    ParamDef {
        name: "AVOID_MEM_HEIGHT",
        unit: "m",
        min: 0.1,
        max: 20.0,
        description: "A remembered obstacle counts within this height of where it was seen from",
        while_armed: WhileArmed::Tunable,
        get: |p| p.memory_height_m,
        set: |p, v| p.memory_height_m = v,
    },
    ParamDef {
        name: "AVOID_MEM_STOP",
        unit: "m",
        min: 0.0,
        max: 10.0,
        description: "The vehicle can always stop this far short of a remembered obstacle",
        while_armed: WhileArmed::Tunable,
        get: |p| p.memory_stop_distance_m,
        set: |p, v| p.memory_stop_distance_m = v,
    },
    ParamDef {
        name: "AVOID_GRID_AGE_S",
        unit: "s",
        min: 0.05,
        max: 5.0,
        description: "Depth grids older than this are ignored",
        while_armed: WhileArmed::Tunable,
        get: |p| p.max_grid_age_s,
        set: |p, v| p.max_grid_age_s = v,
    },
];

/// Sets `name` to `value` in `params` when it is one of ours, in range, and the result
/// validates; otherwise `params` is untouched.
pub fn apply(params: &mut AvoiderParams, name: &str, value: f64) -> Result<ParamChange, ParamRefused> {
    param_def::apply(LIVE_PARAMS, params, name, value, AvoiderParams::validate)
}

/// The declaration for the link (`start` when the actor has just started).
pub fn decl(params: &AvoiderParams, owner: &str, start: bool, now: Time) -> ParamDecl {
    param_def::declare(LIVE_PARAMS, params, owner, start, now)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_declare_a_valid_table() {
        decl(&AvoiderParams::default(), "avoider", true, Time::ZERO).check().expect("valid");
    }

    #[test]
    fn a_setting_applies_and_a_refusal_keeps_the_old_value() {
        let mut p = AvoiderParams::default();
        assert_eq!(apply(&mut p, "AVOID_CLIMB_M_S", 2.0), Ok(ParamChange::Applied));
        assert_eq!(p.climb_speed_m_s, 2.0);
        assert_eq!(apply(&mut p, "RTL_ALT_M", 2.0), Ok(ParamChange::NotMine));
        let before = p.clone();
        // In range, but above the blocked share (0.5).
        assert!(matches!(apply(&mut p, "AVOID_CLIMB_EXIT", 0.8), Err(ParamRefused::Invalid { .. })));
        assert!(matches!(apply(&mut p, "AVOID_SPEED_MAX", 0.0), Err(ParamRefused::OutOfRange { .. })));
        assert_eq!(p, before);
    }
}
