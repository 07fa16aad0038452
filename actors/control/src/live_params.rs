//! The control loop's live parameters: the gains and limits of the position, attitude and rate
//! loops, declared once here with PX4's multicopter names (`MC_ROLLRATE_P`, `MPC_XY_VEL_MAX`,
//! ...) so ground-station users find them. The units are ours, not PX4's: the rate gains are
//! angular acceleration per rate error (the airframe's inertia turns them into torque), and the
//! rate limits are rad/s. Horizontal parameters set north and east together.
//!
//! A change is checked against its range and then the whole [`ControlParams`] validated, in the
//! actor, before the loop sees it: the loop takes a [`Gains`] (plain copied data) between
//! iterations, so retuning never allocates or checks on the 400 Hz path. The airframe and the
//! loop timing are not live: they describe the vehicle and the thread, not a tuning.

use kestrel_proto::Time;
use kestrel_proto::messages::ParamDecl;
use kestrel_proto::param_def::{self, ParamChange, ParamDef, ParamRefused, WhileArmed};

use crate::attitude::AttitudeGains;
use crate::params::ControlParams;
use crate::position::PositionGains;
use crate::rate::RateGains;

/// Every live parameter of the control loop.
pub const LIVE_PARAMS: &[ParamDef<ControlParams>] = &[
    ParamDef {
        name: "MC_ROLL_P",
        unit: "1/s",
        min: 0.1,
        max: 20.0,
        description: "Attitude loop: roll (about forward) rate setpoint per radian of error",
        while_armed: WhileArmed::Tunable,
        get: |p| p.attitude.p[0],
        set: |p, v| p.attitude.p[0] = v,
    },
    ParamDef {
        name: "MC_PITCH_P",
        unit: "1/s",
        min: 0.1,
        max: 20.0,
        description: "Attitude loop: pitch (about right) rate setpoint per radian of error",
        while_armed: WhileArmed::Tunable,
        get: |p| p.attitude.p[1],
        set: |p, v| p.attitude.p[1] = v,
    },
    ParamDef {
        name: "MC_YAW_P",
        unit: "1/s",
        min: 0.1,
        max: 20.0,
        description: "Attitude loop: yaw (about down) rate setpoint per radian of error",
        while_armed: WhileArmed::Tunable,
        get: |p| p.attitude.p[2],
        set: |p, v| p.attitude.p[2] = v,
    },
    ParamDef {
        name: "MC_ROLLRATE_MAX",
        unit: "rad/s",
        min: 0.1,
        max: 20.0,
        description: "Largest roll (about forward) rate setpoint",
        while_armed: WhileArmed::Tunable,
        get: |p| p.attitude.max_rate_rad_s[0],
        set: |p, v| p.attitude.max_rate_rad_s[0] = v,
    },
    ParamDef {
        name: "MC_PITCHRATE_MAX",
        unit: "rad/s",
        min: 0.1,
        max: 20.0,
        description: "Largest pitch (about right) rate setpoint",
        while_armed: WhileArmed::Tunable,
        get: |p| p.attitude.max_rate_rad_s[1],
        set: |p, v| p.attitude.max_rate_rad_s[1] = v,
    },
    ParamDef {
        name: "MC_YAWRATE_MAX",
        unit: "rad/s",
        min: 0.1,
        max: 20.0,
        description: "Largest yaw (about down) rate setpoint",
        while_armed: WhileArmed::Tunable,
        get: |p| p.attitude.max_rate_rad_s[2],
        set: |p, v| p.attitude.max_rate_rad_s[2] = v,
    },
    ParamDef {
        name: "MC_ROLLRATE_P",
        unit: "1/s",
        min: 0.1,
        max: 100.0,
        description: "Rate loop: roll (about forward) angular acceleration per rad/s of rate error",
        while_armed: WhileArmed::Tunable,
        get: |p| p.rate.p[0],
        set: |p, v| p.rate.p[0] = v,
    },
    ParamDef {
        name: "MC_ROLLRATE_I",
        unit: "1/s2",
        min: 0.0,
        max: 100.0,
        description: "Rate loop: roll (about forward) angular acceleration per rad of integrated rate error",
        while_armed: WhileArmed::Tunable,
        get: |p| p.rate.i[0],
        set: |p, v| p.rate.i[0] = v,
    },
    ParamDef {
        name: "MC_ROLLRATE_D",
        unit: "",
        min: 0.0,
        max: 1.0,
        description: "Rate loop: roll (about forward) angular acceleration per rad/s2 of measured angular acceleration",
        while_armed: WhileArmed::Tunable,
        get: |p| p.rate.d[0],
        set: |p, v| p.rate.d[0] = v,
    },
    ParamDef {
        name: "MC_PITCHRATE_P",
        unit: "1/s",
        min: 0.1,
        max: 100.0,
        description: "Rate loop: pitch (about right) angular acceleration per rad/s of rate error",
        while_armed: WhileArmed::Tunable,
        get: |p| p.rate.p[1],
        set: |p, v| p.rate.p[1] = v,
    },
    ParamDef {
        name: "MC_PITCHRATE_I",
        unit: "1/s2",
        min: 0.0,
        max: 100.0,
        description: "Rate loop: pitch (about right) angular acceleration per rad of integrated rate error",
        while_armed: WhileArmed::Tunable,
        get: |p| p.rate.i[1],
        set: |p, v| p.rate.i[1] = v,
    },
    ParamDef {
        name: "MC_PITCHRATE_D",
        unit: "",
        min: 0.0,
        max: 1.0,
        description: "Rate loop: pitch (about right) angular acceleration per rad/s2 of measured angular acceleration",
        while_armed: WhileArmed::Tunable,
        get: |p| p.rate.d[1],
        set: |p, v| p.rate.d[1] = v,
    },
    ParamDef {
        name: "MC_YAWRATE_P",
        unit: "1/s",
        min: 0.1,
        max: 100.0,
        description: "Rate loop: yaw (about down) angular acceleration per rad/s of rate error",
        while_armed: WhileArmed::Tunable,
        get: |p| p.rate.p[2],
        set: |p, v| p.rate.p[2] = v,
    },
    ParamDef {
        name: "MC_YAWRATE_I",
        unit: "1/s2",
        min: 0.0,
        max: 100.0,
        description: "Rate loop: yaw (about down) angular acceleration per rad of integrated rate error",
        while_armed: WhileArmed::Tunable,
        get: |p| p.rate.i[2],
        set: |p, v| p.rate.i[2] = v,
    },
    ParamDef {
        name: "MC_YAWRATE_D",
        unit: "",
        min: 0.0,
        max: 1.0,
        description: "Rate loop: yaw (about down) angular acceleration per rad/s2 of measured angular acceleration",
        while_armed: WhileArmed::Tunable,
        get: |p| p.rate.d[2],
        set: |p, v| p.rate.d[2] = v,
    },
    ParamDef {
        name: "MC_RR_INT_LIM",
        unit: "rad/s2",
        min: 0.0,
        max: 100.0,
        description: "Rate loop: bound of the roll integral term",
        while_armed: WhileArmed::Tunable,
        get: |p| p.rate.integral_limit_rad_s2[0],
        set: |p, v| p.rate.integral_limit_rad_s2[0] = v,
    },
    ParamDef {
        name: "MC_PR_INT_LIM",
        unit: "rad/s2",
        min: 0.0,
        max: 100.0,
        description: "Rate loop: bound of the pitch integral term",
        while_armed: WhileArmed::Tunable,
        get: |p| p.rate.integral_limit_rad_s2[1],
        set: |p, v| p.rate.integral_limit_rad_s2[1] = v,
    },
    ParamDef {
        name: "MC_YR_INT_LIM",
        unit: "rad/s2",
        min: 0.0,
        max: 100.0,
        description: "Rate loop: bound of the yaw integral term",
        while_armed: WhileArmed::Tunable,
        get: |p| p.rate.integral_limit_rad_s2[2],
        set: |p, v| p.rate.integral_limit_rad_s2[2] = v,
    },
    ParamDef {
        name: "MC_DTERM_CUTOFF",
        unit: "Hz",
        min: 1.0,
        max: 200.0,
        description: "Rate loop: cut-off of the derivative's low-pass filter",
        while_armed: WhileArmed::Tunable,
        get: |p| p.rate.derivative_cutoff_hz,
        set: |p, v| p.rate.derivative_cutoff_hz = v,
    },
    ParamDef {
        name: "MPC_XY_P",
        unit: "1/s",
        min: 0.05,
        max: 10.0,
        description: "Position loop: horizontal velocity per metre of position error",
        while_armed: WhileArmed::Tunable,
        get: |p| p.position.position_p[0],
        set: |p, v| {
            p.position.position_p[0] = v;
            p.position.position_p[1] = v;
        },
    },
    ParamDef {
        name: "MPC_Z_P",
        unit: "1/s",
        min: 0.05,
        max: 10.0,
        description: "Position loop: vertical velocity per metre of height error",
        while_armed: WhileArmed::Tunable,
        get: |p| p.position.position_p[2],
        set: |p, v| p.position.position_p[2] = v,
    },
    ParamDef {
        name: "MPC_XY_VEL_P_ACC",
        unit: "1/s",
        min: 0.05,
        max: 20.0,
        description: "Velocity loop: horizontal acceleration per m/s of velocity error",
        while_armed: WhileArmed::Tunable,
        get: |p| p.position.velocity_p[0],
        set: |p, v| {
            p.position.velocity_p[0] = v;
            p.position.velocity_p[1] = v;
        },
    },
    ParamDef {
        name: "MPC_Z_VEL_P_ACC",
        unit: "1/s",
        min: 0.05,
        max: 20.0,
        description: "Velocity loop: vertical acceleration per m/s of velocity error",
        while_armed: WhileArmed::Tunable,
        get: |p| p.position.velocity_p[2],
        set: |p, v| p.position.velocity_p[2] = v,
    },
    ParamDef {
        name: "MPC_XY_VEL_I_ACC",
        unit: "1/s2",
        min: 0.0,
        max: 20.0,
        description: "Velocity loop: horizontal acceleration per metre of integrated velocity error",
        while_armed: WhileArmed::Tunable,
        get: |p| p.position.velocity_i[0],
        set: |p, v| {
            p.position.velocity_i[0] = v;
            p.position.velocity_i[1] = v;
        },
    },
    ParamDef {
        name: "MPC_Z_VEL_I_ACC",
        unit: "1/s2",
        min: 0.0,
        max: 20.0,
        description: "Velocity loop: vertical acceleration per metre of integrated velocity error",
        while_armed: WhileArmed::Tunable,
        get: |p| p.position.velocity_i[2],
        set: |p, v| p.position.velocity_i[2] = v,
    },
    ParamDef {
        name: "MPC_XY_VEL_MAX",
        unit: "m/s",
        min: 0.5,
        max: 20.0,
        description: "Largest horizontal speed",
        while_armed: WhileArmed::Tunable,
        get: |p| p.position.max_horizontal_speed_m_s,
        set: |p, v| p.position.max_horizontal_speed_m_s = v,
    },
    ParamDef {
        name: "MPC_Z_VEL_MAX_UP",
        unit: "m/s",
        min: 0.3,
        max: 10.0,
        description: "Largest climb rate",
        while_armed: WhileArmed::Tunable,
        get: |p| p.position.max_climb_m_s,
        set: |p, v| p.position.max_climb_m_s = v,
    },
    ParamDef {
        name: "MPC_Z_VEL_MAX_DN",
        unit: "m/s",
        min: 0.3,
        max: 10.0,
        description: "Largest descent rate",
        while_armed: WhileArmed::Tunable,
        get: |p| p.position.max_descent_m_s,
        set: |p, v| p.position.max_descent_m_s = v,
    },
    ParamDef {
        name: "MPC_TILTMAX_AIR",
        unit: "deg",
        min: 5.0,
        max: 89.0,
        description: "Largest tilt of the thrust axis from vertical",
        while_armed: WhileArmed::Tunable,
        get: |p| p.position.max_tilt_deg,
        set: |p, v| p.position.max_tilt_deg = v,
    },
    ParamDef {
        name: "MPC_THR_MIN",
        unit: "",
        min: 0.0,
        max: 0.5,
        description: "Least collective thrust in flight, share of maximum",
        while_armed: WhileArmed::Tunable,
        get: |p| p.position.min_thrust,
        set: |p, v| p.position.min_thrust = v,
    },
    ParamDef {
        name: "MPC_THR_MAX",
        unit: "",
        min: 0.1,
        max: 1.0,
        description: "Most collective thrust, share of maximum",
        while_armed: WhileArmed::Tunable,
        get: |p| p.position.max_thrust,
        set: |p, v| p.position.max_thrust = v,
    },
];

/// Gains and limits that passed [`ControlParams::validate`], for the loop to take as they are.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gains {
    pub attitude: AttitudeGains,
    pub rate: RateGains,
    pub position: PositionGains,
}

/// The control loop's parameters as the ground station tunes them.
#[derive(Clone, Debug)]
pub struct Tuning {
    params: ControlParams,
}

impl Tuning {
    /// Starts from `params` (already validated when the controller was built).
    pub fn new(params: ControlParams) -> Tuning {
        Tuning { params }
    }

    /// The parameters in use.
    pub fn params(&self) -> &ControlParams {
        &self.params
    }

    /// Sets `name` to `value` when it is one of ours, in range, and the result validates; the
    /// old value stays otherwise.
    pub fn apply(&mut self, name: &str, value: f64) -> Result<ParamChange, ParamRefused> {
        param_def::apply(LIVE_PARAMS, &mut self.params, name, value, ControlParams::validate)
    }

    /// The gains now in use, for the loop.
    pub fn gains(&self) -> Gains {
        Gains { attitude: self.params.attitude, rate: self.params.rate, position: self.params.position }
    }

    /// The declaration for the link (`start` when the actor has just started).
    pub fn decl(&self, owner: &str, start: bool, now: Time) -> ParamDecl {
        param_def::declare(LIVE_PARAMS, &self.params, owner, start, now)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_declare_a_valid_table() {
        Tuning::new(ControlParams::default()).decl("controller", true, Time::ZERO).check().expect("valid");
    }

    #[test]
    fn a_gain_applies_to_both_horizontal_axes_and_a_refusal_keeps_the_old_one() {
        let mut t = Tuning::new(ControlParams::default());
        assert_eq!(t.apply("MPC_XY_P", 1.5), Ok(ParamChange::Applied));
        assert_eq!(t.gains().position.position_p, [1.5, 1.5, 1.0]);
        assert_eq!(t.apply("MC_ROLLRATE_P", 25.0), Ok(ParamChange::Applied));
        assert_eq!(t.gains().rate.p, [25.0, 18.0, 8.0]);
        assert_eq!(t.apply("RTL_ALT_M", 25.0), Ok(ParamChange::NotMine));
        let before = t.gains();
        assert!(matches!(t.apply("MC_ROLLRATE_P", 500.0), Err(ParamRefused::OutOfRange { .. })));
        // In range, but the maximum thrust must stay 0.05 above the minimum (0.08).
        assert!(matches!(t.apply("MPC_THR_MAX", 0.1), Err(ParamRefused::Invalid { .. })));
        assert_eq!(t.gains(), before);
    }
}
