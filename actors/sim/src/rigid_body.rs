//! Newton–Euler dynamics of a rigid body, integrated with classical fourth-order Runge–Kutta.
//!
//! Position and velocity live in NED, attitude is a unit quaternion rotating body FRD into NED,
//! angular velocity is in FRD. The inertia tensor is diagonal (a symmetric frame). The forces
//! are supplied by a closure evaluated at every Runge–Kutta stage, so forces that depend on the
//! state (drag on velocity, thrust on attitude) are integrated to fourth order too.

use nalgebra::{Quaternion, UnitQuaternion, Vector3};

/// Kinematic state of the body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidBodyState {
    /// Centre of mass from home, north/east/down (m).
    pub position_ned_m: Vector3<f64>,
    /// Velocity over ground, north/east/down (m/s).
    pub velocity_ned_m_s: Vector3<f64>,
    /// Rotation from body FRD to NED.
    pub attitude: UnitQuaternion<f64>,
    /// Angular rate about forward, right, down (rad/s).
    pub angular_velocity_frd_rad_s: Vector3<f64>,
}

impl Default for RigidBodyState {
    fn default() -> RigidBodyState {
        RigidBodyState {
            position_ned_m: Vector3::zeros(),
            velocity_ned_m_s: Vector3::zeros(),
            attitude: UnitQuaternion::identity(),
            angular_velocity_frd_rad_s: Vector3::zeros(),
        }
    }
}

/// Total external force and torque on the body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wrench {
    /// Force in NED, gravity included (N).
    pub force_ned_n: Vector3<f64>,
    /// Torque about the centre of mass in body FRD (N·m).
    pub torque_frd_n_m: Vector3<f64>,
}

/// Mass properties.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidBody {
    /// Mass (kg).
    pub mass_kg: f64,
    /// Principal moments of inertia about forward, right, down (kg·m²).
    pub inertia_frd_kg_m2: Vector3<f64>,
}

/// Time derivative of a [`RigidBodyState`].
struct Derivative {
    velocity: Vector3<f64>,
    acceleration: Vector3<f64>,
    attitude_rate: Quaternion<f64>,
    angular_acceleration: Vector3<f64>,
}

impl RigidBody {
    /// Advances `state` by `dt_s` under the wrench `wrench(stage_state)`; the attitude is
    /// renormalised after each stage.
    pub fn step(&self, state: &mut RigidBodyState, dt_s: f64, wrench: impl Fn(&RigidBodyState) -> Wrench) {
        let k1 = self.derivative(state, &wrench);
        let k2 = self.derivative(&apply(state, &k1, dt_s / 2.0), &wrench);
        let k3 = self.derivative(&apply(state, &k2, dt_s / 2.0), &wrench);
        let k4 = self.derivative(&apply(state, &k3, dt_s), &wrench);
        let sum = |f: fn(&Derivative) -> Vector3<f64>| (f(&k1) + 2.0 * f(&k2) + 2.0 * f(&k3) + f(&k4)) / 6.0;
        let mean = Derivative {
            velocity: sum(|d| d.velocity),
            acceleration: sum(|d| d.acceleration),
            attitude_rate: (k1.attitude_rate
                + k2.attitude_rate * 2.0
                + k3.attitude_rate * 2.0
                + k4.attitude_rate)
                / 6.0,
            angular_acceleration: sum(|d| d.angular_acceleration),
        };
        *state = apply(state, &mean, dt_s);
    }

    fn derivative(&self, s: &RigidBodyState, wrench: &impl Fn(&RigidBodyState) -> Wrench) -> Derivative {
        let w = wrench(s);
        let omega = s.angular_velocity_frd_rad_s;
        let inertia = self.inertia_frd_kg_m2;
        let momentum = inertia.component_mul(&omega);
        let omega_quat = Quaternion::new(0.0, omega.x, omega.y, omega.z);
        Derivative {
            velocity: s.velocity_ned_m_s,
            acceleration: w.force_ned_n / self.mass_kg,
            attitude_rate: s.attitude.into_inner() * omega_quat * 0.5,
            angular_acceleration: (w.torque_frd_n_m - omega.cross(&momentum)).component_div(&inertia),
        }
    }
}

fn apply(s: &RigidBodyState, d: &Derivative, dt_s: f64) -> RigidBodyState {
    RigidBodyState {
        position_ned_m: s.position_ned_m + d.velocity * dt_s,
        velocity_ned_m_s: s.velocity_ned_m_s + d.acceleration * dt_s,
        attitude: UnitQuaternion::new_normalize(s.attitude.into_inner() + d.attitude_rate * dt_s),
        angular_velocity_frd_rad_s: s.angular_velocity_frd_rad_s + d.angular_acceleration * dt_s,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn body() -> RigidBody {
        RigidBody { mass_kg: 1.5, inertia_frd_kg_m2: Vector3::new(0.029, 0.029, 0.055) }
    }

    #[test]
    fn torque_about_one_axis_spins_only_that_axis() {
        for axis in 0..3 {
            let mut torque = Vector3::zeros();
            torque[axis] = 0.05;
            let wrench = Wrench { force_ned_n: Vector3::zeros(), torque_frd_n_m: torque };
            let mut state = RigidBodyState::default();
            for _ in 0..800 {
                body().step(&mut state, 1.25e-3, |_| wrench);
            }
            // 1 s of constant torque: ω = τ/I·t, angle = τ/(2I)·t².
            let omega = state.angular_velocity_frd_rad_s;
            let want_rate = 0.05 / body().inertia_frd_kg_m2[axis];
            let (rotation_axis, angle) = state.attitude.axis_angle().expect("it turned");
            for other in (0..3).filter(|&i| i != axis) {
                assert!(omega[other].abs() < 1e-12, "axis {axis}: ω = {omega}");
                assert!(rotation_axis[other].abs() < 1e-9, "axis {axis}: turned about {rotation_axis:?}");
            }
            assert!((omega[axis] - want_rate).abs() < 1e-9 * want_rate, "axis {axis}: ω = {omega}");
            assert!((angle - want_rate / 2.0).abs() < 1e-6, "axis {axis}: angle {angle}");
            assert!(rotation_axis[axis] > 0.0);
        }
    }

    #[test]
    fn a_spinning_body_turns_about_the_body_axis_it_spins_on() {
        // Pitched up 90°, a roll rate (about body forward) must turn the body about NED down.
        let mut state = RigidBodyState {
            attitude: UnitQuaternion::from_euler_angles(0.0, std::f64::consts::FRAC_PI_2, 0.0),
            angular_velocity_frd_rad_s: Vector3::new(1.0, 0.0, 0.0),
            ..RigidBodyState::default()
        };
        let free =
            |_: &RigidBodyState| Wrench { force_ned_n: Vector3::zeros(), torque_frd_n_m: Vector3::zeros() };
        let start = state.attitude;
        for _ in 0..100 {
            body().step(&mut state, 1e-3, free);
        }
        let turned = state.attitude * start.inverse();
        let (axis, angle) = turned.axis_angle().expect("it turned");
        assert!((angle - 0.1).abs() < 1e-9, "{angle}");
        assert!((axis.z.abs() - 1.0).abs() < 1e-9, "{axis:?}");
    }

    proptest! {
        #[test]
        fn attitude_stays_unit_and_energy_matches_work_under_random_torques(
            torques in prop::collection::vec(prop::array::uniform3(-1.0f64..1.0), 1..50),
        ) {
            let b = body();
            let mut state = RigidBodyState::default();
            let dt = 2.5e-3;
            let mut work_j = 0.0;
            for t in &torques {
                let torque = Vector3::from(*t);
                for _ in 0..8 {
                    let before = state.angular_velocity_frd_rad_s;
                    b.step(&mut state, dt, |_| Wrench { force_ned_n: Vector3::zeros(), torque_frd_n_m: torque });
                    work_j += torque.dot(&(before + state.angular_velocity_frd_rad_s)) / 2.0 * dt;
                }
                prop_assert!((state.attitude.into_inner().norm() - 1.0).abs() < 1e-12);
            }
            let w = state.angular_velocity_frd_rad_s;
            let energy_j = 0.5 * w.dot(&b.inertia_frd_kg_m2.component_mul(&w));
            prop_assert!((energy_j - work_j).abs() < 1e-4 * (1.0 + energy_j), "{energy_j} vs {work_j}");
        }
    }
}
