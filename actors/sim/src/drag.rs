//! Airframe drag: a linear term (rotor induced drag, dominant at low speed) plus a quadratic
//! term (body form drag), both opposing the velocity *relative to the air*. Isotropic: a
//! multirotor's drag differs little between axes at the speeds it flies, and the estimator does
//! not model it anyway.
//!
//! And rotational drag about the yaw axis, a torque −γ·r opposing the body's yaw rate r (the
//! air the arms and rotors drag round with them). It is what bounds the spin of a quad that
//! lost a motor and can no longer balance its rotors' reaction torques (Mueller & D'Andrea,
//! ICRA 2014, model it the same way); at the yaw rates of ordinary flight (≤ 1 rad/s) it is a
//! hundredth of a newton-metre, which the yaw loop's integrator takes up. Roll and pitch
//! rates stay short-lived in flight, and are left undamped.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, non_negative};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DragParams {
    /// Force per unit airspeed (N per m/s).
    pub linear_n_per_m_s: f64,
    /// Force per unit airspeed squared (N per (m/s)²).
    pub quadratic_n_per_m2_s2: f64,
    /// Yaw torque per unit yaw rate, γ (N·m per rad/s), opposing the rate about body down.
    pub yaw_n_m_per_rad_s: f64,
}

impl Default for DragParams {
    /// About 6 N at 10 m/s for a 450-size quad, i.e. a 22° lean to hold that speed. γ: Mueller
    /// & D'Andrea's 2.75e-3 N·m·s/rad for their 0.5 kg, 0.17 m-arm vehicle, scaled by mass ×
    /// arm² (the air's moment arm and the swept area grow with both) to the 1.5 kg, 0.225 m
    /// quad: 0.0144 N·m·s/rad. The quad spinning on the two rotors beside a lost one (0.235 N·m
    /// of reaction torque at hover) then settles near 16 rad/s, with a time constant
    /// I_zz/γ = 3.8 s.
    fn default() -> DragParams {
        DragParams { linear_n_per_m_s: 0.15, quadratic_n_per_m2_s2: 0.045, yaw_n_m_per_rad_s: 0.0144 }
    }
}

impl DragParams {
    pub(crate) fn validate(&self) -> Result<(), InvalidParam> {
        non_negative("linear_n_per_m_s", self.linear_n_per_m_s)?;
        non_negative("quadratic_n_per_m2_s2", self.quadratic_n_per_m2_s2)?;
        non_negative("yaw_n_m_per_rad_s", self.yaw_n_m_per_rad_s)
    }

    /// Drag force (N, NED) for an airspeed vector `air_velocity_ned_m_s`.
    pub(crate) fn force_ned_n(&self, air_velocity_ned_m_s: &Vector3<f64>) -> Vector3<f64> {
        let speed = air_velocity_ned_m_s.norm();
        -(self.linear_n_per_m_s + self.quadratic_n_per_m2_s2 * speed) * air_velocity_ned_m_s
    }

    /// Rotational drag torque (N·m, body FRD) at the body rate `angular_velocity_frd_rad_s`.
    pub(crate) fn torque_frd_n_m(&self, angular_velocity_frd_rad_s: &Vector3<f64>) -> Vector3<f64> {
        Vector3::new(0.0, 0.0, -self.yaw_n_m_per_rad_s * angular_velocity_frd_rad_s.z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rigid_body::{RigidBody, RigidBodyState, Wrench};

    #[test]
    fn a_free_spin_decays_exponentially_with_time_constant_inertia_over_gamma() {
        let drag = DragParams::default();
        let body = RigidBody { mass_kg: 1.5, inertia_frd_kg_m2: Vector3::new(0.029, 0.029, 0.055) };
        let mut state =
            RigidBodyState { angular_velocity_frd_rad_s: Vector3::new(0.0, 0.0, 16.0), ..Default::default() };
        let dt = 1e-3;
        for _ in 0..2000 {
            body.step(&mut state, dt, |s| Wrench {
                force_ned_n: Vector3::zeros(),
                torque_frd_n_m: drag.torque_frd_n_m(&s.angular_velocity_frd_rad_s),
            });
        }
        // I·ṙ = −γ·r: r(t) = r₀·exp(−γ·t/I), here after 2 s.
        let want = 16.0 * (-drag.yaw_n_m_per_rad_s * 2.0 / 0.055f64).exp();
        let r = state.angular_velocity_frd_rad_s.z;
        assert!((r - want).abs() < 1e-9 * want, "{r} vs {want}");
    }

    #[test]
    fn the_lost_motor_spin_settles_where_reaction_torque_meets_drag() {
        // Two rotors carrying 1.5 kg: 2 × 7.36 N × k_m/k_f (0.016 m) of reaction torque.
        let reaction_n_m = 1.5 * 9.80665 * 0.016;
        let r = reaction_n_m / DragParams::default().yaw_n_m_per_rad_s;
        assert!((15.0..18.0).contains(&r), "{r} rad/s");
        assert!(
            DragParams::default().torque_frd_n_m(&Vector3::new(3.0, -2.0, 1.0)).xy() == Vector3::zeros().xy()
        );
    }

    #[test]
    fn a_negative_coefficient_is_refused_by_name() {
        let bad = DragParams { yaw_n_m_per_rad_s: -0.01, ..DragParams::default() };
        let err = bad.validate().expect_err("negative");
        assert!(err.to_string().contains("yaw_n_m_per_rad_s"), "{err}");
    }
}
