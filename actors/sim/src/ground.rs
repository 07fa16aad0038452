//! Ground contact: flat ground at home altitude (down = 0), which the vehicle's centre never
//! passes. Touching it stops the vehicle (an inelastic, high-friction contact); touching it too
//! fast or too tilted is a crash.
//!
//! The model is deliberately simple, like jMAVSim's: no bounce, no sliding, no tipping
//! dynamics. It keeps a landed vehicle still (so its IMU reads exactly −g) and catches the
//! events that matter to a flight stack: take-off, touchdown, hard landing, tip-over.

use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, positive};
use crate::rigid_body::RigidBodyState;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ContactParams {
    /// Touching the ground faster than this is a crash (m/s).
    pub crash_speed_m_s: f64,
    /// Touching the ground tilted more than this from level is a tip-over crash (degrees).
    pub tip_over_deg: f64,
    /// Radius of the sphere around the centre that must not touch an obstacle (m): arm plus
    /// propeller radius.
    pub collision_radius_m: f64,
}

impl Default for ContactParams {
    fn default() -> ContactParams {
        ContactParams { crash_speed_m_s: 3.0, tip_over_deg: 60.0, collision_radius_m: 0.35 }
    }
}

impl ContactParams {
    pub(crate) fn validate(&self) -> Result<(), InvalidParam> {
        positive("crash_speed_m_s", self.crash_speed_m_s)?;
        positive("tip_over_deg", self.tip_over_deg)?;
        positive("collision_radius_m", self.collision_radius_m)
    }
}

/// Contact state, updated after every physics step.
#[derive(Clone, Debug, Default)]
pub(crate) struct Ground {
    pub(crate) landed: bool,
    pub(crate) crashed: bool,
}

impl Ground {
    /// Resolves penetration of the ground after a physics step.
    pub(crate) fn resolve(&mut self, params: &ContactParams, state: &mut RigidBodyState) {
        let touching = state.position_ned_m.z > 0.0
            || (state.position_ned_m.z == 0.0 && state.velocity_ned_m_s.z >= 0.0);
        if !touching {
            self.landed = false;
            return;
        }
        let body_down_ned = state.attitude * nalgebra::Vector3::z();
        let tilt_deg = body_down_ned.z.clamp(-1.0, 1.0).acos().to_degrees();
        if state.velocity_ned_m_s.norm() > params.crash_speed_m_s || tilt_deg > params.tip_over_deg {
            self.crashed = true;
        }
        state.position_ned_m.z = 0.0;
        state.velocity_ned_m_s = nalgebra::Vector3::zeros();
        state.angular_velocity_frd_rad_s = nalgebra::Vector3::zeros();
        self.landed = true;
    }
}
