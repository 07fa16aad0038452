//! Attitude control on the rotation group SO(3).
//!
//! The error is intrinsic: the rotation vector (axis × angle, body FRD) of `R⁻¹·R_d`, i.e. the
//! Riemannian logarithm, the gradient of the geodesic potential ½θ². This is the
//! configuration error of the intrinsic nonlinear PID of Maithripala & Berg (thesis ref. \[1\])
//! and Lee, Leok & McClamroch (2010, ref. \[2\]) with one deliberate change: Lee's trace
//! potential ½·tr(I − R_dᵀR) has the gradient `sin θ · axis`, which fades to zero as the
//! error approaches 180°, so a vehicle upside down barely moves at first. The geodesic
//! gradient grows with θ up to π, so recovery from 170° starts at full authority. The log map
//! is discontinuous only at θ = π (a set of measure zero), where the tilt-first reduction below
//! picks a roll axis: no continuous feedback can stabilise SO(3) globally, so almost-global is
//! the best available. A property test checks the two errors agree up to the factor sin θ/θ.
//!
//! Like PX4 (`AttitudeControl.cpp`), tilt is prioritised over heading: the target is first
//! reduced to the rotation that only aligns the thrust axis, and the heading part is added back
//! with weight `yaw_p / roll_p`. The output is a body-rate setpoint for the inner
//! [`RateController`](crate::rate::RateController); together the two loops form the intrinsic
//! PID: P on the SO(3) error here, D (rate error) and I in the rate loop, with the gyroscopic
//! feed-forward `ω × Jω` of Lee et al.

use nalgebra::{UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, positive};

/// `[attitude]` gains and limits. Defaults are tuned for quad_x.toml inside the default rate loop.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AttitudeGains {
    /// Rate setpoint per radian of error about forward, right, down (1/s).
    pub p: [f64; 3],
    /// Largest body-rate setpoint about forward, right, down (rad/s).
    pub max_rate_rad_s: [f64; 3],
}

impl Default for AttitudeGains {
    fn default() -> AttitudeGains {
        AttitudeGains { p: [6.5, 6.5, 2.8], max_rate_rad_s: [3.8, 3.8, 1.6] }
    }
}

impl AttitudeGains {
    pub(crate) fn validate(&self) -> Result<(), InvalidParam> {
        for i in 0..3 {
            positive(&format!("attitude.p[{i}]"), self.p[i])?;
            positive(&format!("attitude.max_rate_rad_s[{i}]"), self.max_rate_rad_s[i])?;
        }
        Ok(())
    }
}

/// The rotation vector (body FRD, rad) that takes attitude `q` to `q_d` along the shortest
/// geodesic: `log(q⁻¹·q_d)`, with angle in 0..=π.
pub fn attitude_error(q: &UnitQuaternion<f64>, q_d: &UnitQuaternion<f64>) -> Vector3<f64> {
    let mut e = (q.inverse() * q_d).into_inner();
    if e.w < 0.0 {
        e = -e;
    }
    let sin_half = e.imag().norm();
    if sin_half < 1e-12 {
        return 2.0 * e.imag();
    }
    let angle = 2.0 * sin_half.atan2(e.w);
    e.imag() * (angle / sin_half)
}

/// The attitude whose thrust axis is that of `q_d` reached from `q` by the smallest tilt.
fn reduced_target(q: &UnitQuaternion<f64>, q_d: &UnitQuaternion<f64>) -> UnitQuaternion<f64> {
    let z = q * Vector3::z();
    let z_d = q_d * Vector3::z();
    let tilt = UnitQuaternion::rotation_between(&z, &z_d).unwrap_or_else(|| {
        // Exactly opposite thrust axes: any horizontal axis is shortest; roll about body forward.
        UnitQuaternion::from_axis_angle(
            &nalgebra::Unit::new_normalize(q * Vector3::x()),
            std::f64::consts::PI,
        )
    });
    tilt * q
}

/// The outer, attitude loop: attitude setpoint → body-rate setpoint.
#[derive(Clone, Debug)]
pub struct AttitudeController {
    gains: AttitudeGains,
}

impl AttitudeController {
    pub fn new(gains: AttitudeGains) -> AttitudeController {
        AttitudeController { gains }
    }

    /// Takes new (validated) gains from the next step on.
    pub fn set_gains(&mut self, gains: AttitudeGains) {
        self.gains = gains;
    }

    /// Body-rate setpoint (FRD, rad/s) to bring attitude `q` to `q_d`, plus a heading-rate
    /// feed-forward `yaw_rate_ff_rad_s` about earth down.
    pub fn rate_setpoint(
        &self,
        q: &UnitQuaternion<f64>,
        q_d: &UnitQuaternion<f64>,
        yaw_rate_ff_rad_s: f64,
    ) -> Vector3<f64> {
        let g = &self.gains;
        let reduced = reduced_target(q, q_d);
        // Heading part: a rotation about the (now aligned) thrust axis, weighted down.
        let yaw_weight = (g.p[2] / g.p[0]).clamp(0.0, 1.0);
        let heading = reduced.inverse() * q_d;
        let heading = UnitQuaternion::identity().slerp(&heading_shortest(heading), yaw_weight);
        let target = reduced * heading;
        let e = attitude_error(q, &target);
        let mut rate = Vector3::new(g.p[0] * e.x, g.p[1] * e.y, g.p[2] * e.z / yaw_weight.max(1e-6));
        // Heading-rate feed-forward: earth down expressed in the body frame.
        rate += q.inverse() * Vector3::z() * yaw_rate_ff_rad_s;
        for i in 0..3 {
            rate[i] = rate[i].clamp(-g.max_rate_rad_s[i], g.max_rate_rad_s[i]);
        }
        rate
    }
}

/// `q` or `-q`, whichever has a non-negative scalar part (the shorter way round).
fn heading_shortest(q: UnitQuaternion<f64>) -> UnitQuaternion<f64> {
    if q.w < 0.0 { UnitQuaternion::new_unchecked(-q.into_inner()) } else { q }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Unit};
    use proptest::prelude::*;

    /// Lee, Leok & McClamroch (2010) eq. (10): e_R = ½ (R_dᵀR − RᵀR_d)^∨.
    fn lee_error(q: &UnitQuaternion<f64>, q_d: &UnitQuaternion<f64>) -> Vector3<f64> {
        let r: Matrix3<f64> = q.to_rotation_matrix().into_inner();
        let r_d: Matrix3<f64> = q_d.to_rotation_matrix().into_inner();
        let m = (r_d.transpose() * r - r.transpose() * r_d) * 0.5;
        Vector3::new(m[(2, 1)], m[(0, 2)], m[(1, 0)])
    }

    proptest! {
        #[test]
        fn geodesic_error_matches_lee_error_up_to_the_sine(
            ax in -1.0f64..1.0, ay in -1.0f64..1.0, az in -1.0f64..1.0,
            bx in -1.0f64..1.0, by in -1.0f64..1.0, bz in -1.0f64..1.0, angle in 0.01f64..3.1,
        ) {
            let a = Vector3::new(ax, ay, az);
            let b = Vector3::new(bx, by, bz);
            prop_assume!(a.norm() > 0.1 && b.norm() > 0.1);
            let q_d = UnitQuaternion::from_scaled_axis(b);
            let q = q_d * UnitQuaternion::from_axis_angle(&Unit::new_normalize(a), angle);
            let e = attitude_error(&q, &q_d);
            // Ours is the rotation from current to desired (−axis·θ); Lee's is sin θ·axis.
            let expected = -lee_error(&q, &q_d);
            prop_assert!((e.norm() - angle).abs() < 1e-9);
            prop_assert!((e * (angle.sin() / angle) - expected).norm() < 1e-9, "{e} vs {expected}");
        }
    }

    #[test]
    fn upside_down_demands_a_full_rate_roll() {
        let ctl = AttitudeController::new(AttitudeGains::default());
        let q = UnitQuaternion::from_euler_angles(170f64.to_radians(), 0.0, 0.0);
        let rate = ctl.rate_setpoint(&q, &UnitQuaternion::identity(), 0.0);
        assert!((rate.x + 3.8).abs() < 1e-9, "{rate}");
        let q = UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 0.0);
        let rate = ctl.rate_setpoint(&q, &UnitQuaternion::identity(), 0.0);
        assert!(rate.x.abs() > 3.0, "exactly inverted still rolls: {rate}");
    }

    #[test]
    fn heading_error_is_weighted_below_tilt() {
        let ctl = AttitudeController::new(AttitudeGains::default());
        let q_d = UnitQuaternion::from_euler_angles(0.0, 0.0, 0.2);
        let rate = ctl.rate_setpoint(&UnitQuaternion::identity(), &q_d, 0.0);
        assert!((rate.z - 2.8 * 0.2).abs() < 1e-6 && rate.x.abs() < 1e-9, "{rate}");
    }
}
