//! The estimator's live parameters: the noises and innovation gates of [`EkfParams`], declared
//! once here with PX4 EKF2's names (`EKF2_ACC_NOISE`, `EKF2_GPS_GATE`, ...) and our units. The
//! sensor lags, alignment and the lag compensation switch size the delay buffers and the
//! fusion horizon, so they are not live: they change with the config and a restart.
//!
//! The ranges bound what a filter can sensibly be tuned to; [`EkfParams::validate`] runs again on
//! the changed struct, and a refusal keeps the old value.

use kestrel_proto::Time;
use kestrel_proto::messages::ParamDecl;
use kestrel_proto::param_def::{self, ParamChange, ParamDef, ParamRefused, WhileArmed};

use crate::params::EkfParams;

/// Every live parameter of the estimator.
pub const LIVE_PARAMS: &[ParamDef<EkfParams>] = &[
    ParamDef {
        name: "EKF2_GYR_NOISE",
        unit: "rad/s",
        min: 0.0001,
        max: 0.5,
        description: "Gyro white noise driving attitude uncertainty",
        while_armed: WhileArmed::Tunable,
        get: |p| p.gyro_noise_rad_s,
        set: |p, v| p.gyro_noise_rad_s = v,
    },
    ParamDef {
        name: "EKF2_ACC_NOISE",
        unit: "m/s2",
        min: 0.01,
        max: 5.0,
        description: "Accelerometer white noise driving velocity uncertainty (thesis 0.25)",
        while_armed: WhileArmed::Tunable,
        get: |p| p.accel_noise_m_s2,
        set: |p, v| p.accel_noise_m_s2 = v,
    },
    ParamDef {
        name: "EKF2_GYR_B_NOISE",
        unit: "rad/s2",
        min: 1e-06,
        max: 0.1,
        description: "Gyro bias random walk",
        while_armed: WhileArmed::Tunable,
        get: |p| p.gyro_bias_noise_rad_s2,
        set: |p, v| p.gyro_bias_noise_rad_s2 = v,
    },
    ParamDef {
        name: "EKF2_ACC_B_NOISE",
        unit: "m/s3",
        min: 1e-06,
        max: 0.1,
        description: "Accelerometer bias random walk",
        while_armed: WhileArmed::Tunable,
        get: |p| p.accel_bias_noise_m_s3,
        set: |p, v| p.accel_bias_noise_m_s3 = v,
    },
    ParamDef {
        name: "EKF2_GPS_P_NOISE",
        unit: "m",
        min: 0.01,
        max: 20.0,
        description: "GPS horizontal position noise (the receiver's accuracy when larger)",
        while_armed: WhileArmed::Tunable,
        get: |p| p.gps_position_noise_m,
        set: |p, v| p.gps_position_noise_m = v,
    },
    ParamDef {
        name: "EKF2_GPS_V_NOISE",
        unit: "m/s",
        min: 0.01,
        max: 10.0,
        description: "GPS velocity noise (the receiver's accuracy when larger)",
        while_armed: WhileArmed::Tunable,
        get: |p| p.gps_velocity_noise_m_s,
        set: |p, v| p.gps_velocity_noise_m_s = v,
    },
    ParamDef {
        name: "EKF2_BARO_NOISE",
        unit: "m",
        min: 0.01,
        max: 20.0,
        description: "Barometric height noise",
        while_armed: WhileArmed::Tunable,
        get: |p| p.baro_height_noise_m,
        set: |p, v| p.baro_height_noise_m = v,
    },
    ParamDef {
        name: "EKF2_BAROV_NOISE",
        unit: "m/s",
        min: 0.01,
        max: 20.0,
        description: "Noise of the climb rate differentiated from the barometer",
        while_armed: WhileArmed::Tunable,
        get: |p| p.baro_climb_rate_noise_m_s,
        set: |p, v| p.baro_climb_rate_noise_m_s = v,
    },
    ParamDef {
        name: "EKF2_MAG_NOISE",
        unit: "gauss",
        min: 0.001,
        max: 1.0,
        description: "Magnetometer noise per axis",
        while_armed: WhileArmed::Tunable,
        get: |p| p.mag_noise_gauss,
        set: |p, v| p.mag_noise_gauss = v,
    },
    ParamDef {
        name: "EKF2_GPS_GATE",
        unit: "SD",
        min: 1.0,
        max: 20.0,
        description: "Innovation gate of GPS position and velocity",
        while_armed: WhileArmed::Tunable,
        get: |p| p.gps_gate_sigma,
        set: |p, v| p.gps_gate_sigma = v,
    },
    ParamDef {
        name: "EKF2_BARO_GATE",
        unit: "SD",
        min: 1.0,
        max: 20.0,
        description: "Innovation gate of barometric height and climb rate",
        while_armed: WhileArmed::Tunable,
        get: |p| p.baro_gate_sigma,
        set: |p, v| p.baro_gate_sigma = v,
    },
    ParamDef {
        name: "EKF2_MAG_GATE",
        unit: "SD",
        min: 1.0,
        max: 20.0,
        description: "Innovation gate of each magnetometer axis",
        while_armed: WhileArmed::Tunable,
        get: |p| p.mag_gate_sigma,
        set: |p, v| p.mag_gate_sigma = v,
    },
    ParamDef {
        name: "EKF2_REQ_EPH",
        unit: "m",
        min: 0.5,
        max: 50.0,
        description: "Largest reported GPS horizontal accuracy for a fix to be used",
        while_armed: WhileArmed::Tunable,
        get: |p| p.gps_max_h_acc_m,
        set: |p, v| p.gps_max_h_acc_m = v,
    },
    ParamDef {
        name: "EKF2_GPS_RST_S",
        unit: "s",
        min: 0.5,
        max: 60.0,
        description: "GPS position or velocity rejected this long resets it to GPS",
        while_armed: WhileArmed::Tunable,
        get: |p| p.gps_reset_timeout_s,
        set: |p, v| p.gps_reset_timeout_s = v,
    },
    ParamDef {
        name: "EKF2_GPS_RST_M",
        unit: "m",
        min: 5.0,
        max: 1000.0,
        description: "Longest GPS position reset taken; a longer one is refused and the position invalid",
        while_armed: WhileArmed::Tunable,
        get: |p| p.gps_reset_max_m,
        set: |p, v| p.gps_reset_max_m = v,
    },
];

/// Sets `name` to `value` in `params` when it is one of ours, in range, and the result
/// validates; otherwise `params` is untouched.
pub fn apply(params: &mut EkfParams, name: &str, value: f64) -> Result<ParamChange, ParamRefused> {
    param_def::apply(LIVE_PARAMS, params, name, value, EkfParams::validate)
}

/// The declaration for the link (`start` when the actor has just started).
pub fn decl(params: &EkfParams, owner: &str, start: bool, now: Time) -> ParamDecl {
    param_def::declare(LIVE_PARAMS, params, owner, start, now)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_declare_a_valid_table() {
        decl(&EkfParams::default(), "estimator", true, Time::ZERO).check().expect("valid");
    }

    #[test]
    fn a_noise_applies_and_a_refusal_keeps_the_old_value() {
        let mut p = EkfParams::default();
        assert_eq!(apply(&mut p, "EKF2_GPS_P_NOISE", 3.0), Ok(ParamChange::Applied));
        assert_eq!(p.gps_position_noise_m, 3.0);
        assert_eq!(apply(&mut p, "MC_ROLL_P", 3.0), Ok(ParamChange::NotMine));
        let before = p.clone();
        assert!(apply(&mut p, "EKF2_GPS_GATE", 0.0).is_err());
        assert!(apply(&mut p, "EKF2_ACC_NOISE", f64::INFINITY).is_err());
        assert_eq!(p, before);
    }
}
