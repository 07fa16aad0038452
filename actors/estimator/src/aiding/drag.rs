//! Multirotor drag, the maths. A multirotor's thrust acts along its body z axis only, so what
//! its accelerometer reads along body x and y is the drag of the air flowing past it: the
//! accelerometer measures the air-relative velocity. With the wind known, that is the velocity
//! over the ground, without GPS. PX4 EKF2 fuses it with `EKF2_DRAG_CTRL` (`EKF2_MCOEF`,
//! `EKF2_BCOEF_X/Y`) and ArduPilot EKF3 dead reckons on it after a GPS loss (`EK3_DRAG_MCOEF`,
//! `EK3_DRAG_BCOEF_X/Y`); both carry the wind as filter states. This filter has none (its 16
//! states are the thesis's), so the wind is learnt beside it while GPS velocity is fused and
//! held when GPS is lost ([`crate::aiding::drag_control`]), and the drag is fused as an
//! observation of the body-axis air velocity, `(Rᵀ·(v − w))ₓ,ᵧ`, against the velocity states.
//!
//! The model per unit mass, f = −(k₁ + k₂·|v_air|)·v_air, is the simulator's
//! (actors/sim/src/drag.rs) divided by the vehicle's mass. The attitude's share of the
//! observation's Jacobian is left out: a heading error turns the measured air velocity, and
//! `drag_velocity_noise_m_s` carries it instead; yaw stays the magnetometer's to correct.

use kestrel_proto::messages::Innovation;
use nalgebra::Vector3;

use crate::aiding::innovation;
use crate::covariance::SparseRow;
use crate::filter::Filter;
use crate::state::VEL;

/// Newton steps solving the drag model for the airspeed: from an upper bound on a convex,
/// increasing function they converge from above, to 1e-12 relative within six at any speed a
/// multirotor flies.
const NEWTON_STEPS: usize = 8;

/// The drag model, per unit mass (`EkfParams::drag_linear_per_s`, `drag_quadratic_per_m`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DragModel {
    /// k₁ (1/s).
    pub linear_per_s: f64,
    /// k₂ (1/m).
    pub quadratic_per_m: f64,
}

impl DragModel {
    /// Whether there is a model to fuse with (both coefficients 0: drag fusion off).
    pub fn enabled(&self) -> bool {
        self.linear_per_s > 0.0 || self.quadratic_per_m > 0.0
    }

    /// The specific force (m/s², body FRD) the drag puts on body x and y at the body-frame air
    /// velocity `air_frd_m_s` (the velocity of the body relative to the air).
    pub fn specific_force_xy(&self, air_frd_m_s: &Vector3<f64>) -> [f64; 2] {
        let slope = self.linear_per_s + self.quadratic_per_m * air_frd_m_s.norm();
        [-slope * air_frd_m_s.x, -slope * air_frd_m_s.y]
    }

    /// The body x and y air velocity (m/s, FRD) whose drag reads as `force_xy_m_s2` on the
    /// accelerometer, given the air velocity along body z `down_m_s` (which the quadratic
    /// term's speed includes and drag along x and y cannot tell). Points against the force.
    pub fn air_velocity_xy(&self, force_xy_m_s2: [f64; 2], down_m_s: f64) -> [f64; 2] {
        let force = force_xy_m_s2[0].hypot(force_xy_m_s2[1]);
        if force == 0.0 || !self.enabled() {
            return [0.0, 0.0];
        }
        let (k1, k2, z) = (self.linear_per_s, self.quadratic_per_m, down_m_s.abs());
        // g(a) = (k₁ + k₂·√(a² + z²))·a − |f| is increasing and convex in the horizontal
        // airspeed a ≥ 0; both bounds lie at or above its root.
        let mut speed = f64::INFINITY;
        if k1 + k2 * z > 0.0 {
            speed = force / (k1 + k2 * z);
        }
        if k2 > 0.0 {
            speed = speed.min((force / k2).sqrt());
        }
        for _ in 0..NEWTON_STEPS {
            let s = speed.hypot(z);
            let g = (k1 + k2 * s) * speed - force;
            let slope = k1 + k2 * s + if s > 0.0 { k2 * speed * speed / s } else { 0.0 };
            if slope <= 0.0 {
                break;
            }
            speed = (speed - g / slope).max(0.0);
        }
        [-speed * force_xy_m_s2[0] / force, -speed * force_xy_m_s2[1] / force]
    }
}

/// The filter's body-frame air velocity (m/s, FRD) in a wind `wind_ne_m_s` (m/s, north and east,
/// the air's velocity over the ground; no vertical wind).
pub fn predicted_air_velocity(filter: &Filter, wind_ne_m_s: [f64; 2]) -> Vector3<f64> {
    let s = &filter.state;
    let air_ned = s.vel_ned_m_s - Vector3::new(wind_ne_m_s[0], wind_ne_m_s[1], 0.0);
    s.attitude.inverse_transform_vector(&air_ned)
}

/// The wind (m/s, north and east) that the air velocity `measured_xy_m_s` (body x and y, from
/// drag) and the filter's velocity imply; body z's air velocity is taken from the filter with the
/// wind `wind_ne_m_s` held so far.
pub fn wind_observation(filter: &Filter, measured_xy_m_s: [f64; 2], wind_ne_m_s: [f64; 2]) -> [f64; 2] {
    let down = predicted_air_velocity(filter, wind_ne_m_s).z;
    let air_ned =
        filter.state.attitude.transform_vector(&Vector3::new(measured_xy_m_s[0], measured_xy_m_s[1], down));
    let v = filter.state.vel_ned_m_s;
    [v.x - air_ned.x, v.y - air_ned.y]
}

/// The Jacobian row of body axis `axis`'s air velocity against the velocity states: that axis
/// in NED, the attitude matrix's column.
fn row(filter: &Filter, axis: usize) -> SparseRow {
    let column = filter.state.attitude.to_rotation_matrix().matrix().column(axis).into_owned();
    SparseRow::block3(VEL, [column.x, column.y, column.z])
}

/// Innovations of body x and y air velocity, gated at `gate_sigma`.
pub fn air_velocity_innovations(
    filter: &Filter,
    measured_xy_m_s: [f64; 2],
    wind_ne_m_s: [f64; 2],
    variance_m2_s2: f64,
    gate_sigma: f64,
) -> [Innovation; 2] {
    let predicted = predicted_air_velocity(filter, wind_ne_m_s);
    std::array::from_fn(|axis| {
        innovation(
            measured_xy_m_s[axis] - predicted[axis],
            filter.innovation_variance(&row(filter, axis), variance_m2_s2),
            gate_sigma,
        )
    })
}

/// Fuses body x and y air velocity as sequential scalars; whether either was taken.
pub fn fuse_air_velocity(
    filter: &mut Filter,
    measured_xy_m_s: [f64; 2],
    wind_ne_m_s: [f64; 2],
    variance_m2_s2: f64,
) -> bool {
    (0..2).fold(false, |fused, axis| {
        let y = measured_xy_m_s[axis] - predicted_air_velocity(filter, wind_ne_m_s)[axis];
        let h = row(filter, axis);
        filter.fuse(&h, y, variance_m2_s2) | fused
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use kestrel_proto::Time;
    use nalgebra::UnitQuaternion;
    use proptest::prelude::*;

    use crate::state::State;

    const QUAD: DragModel = DragModel { linear_per_s: 0.1, quadratic_per_m: 0.03 };

    fn filter(roll: f64, pitch: f64, yaw: f64, vel: [f64; 3]) -> Filter {
        let attitude = UnitQuaternion::from_euler_angles(roll, pitch, yaw);
        let state = State { vel_ned_m_s: Vector3::from(vel), ..State::at_rest(Time::ZERO, attitude) };
        Filter::aligned(state, true)
    }

    proptest! {
        /// Inverting the model gives back the air velocity the forward model started from.
        #[test]
        fn the_inverse_returns_the_air_velocity_the_force_came_from(
            x in -15.0f64..15.0, y in -15.0f64..15.0, z in -5.0f64..5.0,
            k1 in 0.0f64..0.5, k2 in 0.0f64..0.1,
        ) {
            prop_assume!(k1 + k2 > 1e-3);
            let model = DragModel { linear_per_s: k1, quadratic_per_m: k2 };
            let air = Vector3::new(x, y, z);
            let back = model.air_velocity_xy(model.specific_force_xy(&air), z);
            prop_assert!((back[0] - x).abs() < 1e-9 * (1.0 + x.abs()), "{back:?} vs {air:?}");
            prop_assert!((back[1] - y).abs() < 1e-9 * (1.0 + y.abs()), "{back:?} vs {air:?}");
        }
    }

    /// The signs, by hand: flying forward at 3 m/s through still air, drag pushes back with
    /// (0.1 + 0.03·3)·3 = 0.57 m/s²; a 2 m/s wind from the right pushes left.
    #[test]
    fn drag_pushes_against_the_air_velocity() {
        let [x, y] = QUAD.specific_force_xy(&Vector3::new(3.0, 0.0, 0.0));
        assert!((x + 0.57).abs() < 1e-12 && y == 0.0, "{x} {y}");
        // Wind from the right (blowing towards body left, −y): the body moves +2 m/s through it.
        let [x, y] = QUAD.specific_force_xy(&Vector3::new(0.0, 2.0, 0.0));
        assert!(x == 0.0 && (y + (0.1 + 0.06) * 2.0).abs() < 1e-12, "{x} {y}");
    }

    #[test]
    fn no_force_is_no_airspeed_and_no_model_measures_nothing() {
        assert_eq!(QUAD.air_velocity_xy([0.0, 0.0], 3.0), [0.0, 0.0]);
        let off = DragModel { linear_per_s: 0.0, quadratic_per_m: 0.0 };
        assert!(!off.enabled());
        assert_eq!(off.air_velocity_xy([0.3, 0.1], 0.0), [0.0, 0.0]);
    }

    /// The Jacobian against finite differences of the predicted air velocity, tilted and yawed.
    #[test]
    fn the_jacobian_is_the_derivative_of_the_predicted_air_velocity() {
        let f = filter(0.2, -0.15, 2.3, [3.0, -1.0, 0.5]);
        let wind = [0.7, -0.4];
        for axis in 0..2 {
            let h = row(&f, axis).dense();
            for v in 0..3 {
                let step = 1e-6;
                let mut moved = f.clone();
                moved.state.vel_ned_m_s[v] += step;
                let numeric = (predicted_air_velocity(&moved, wind)[axis]
                    - predicted_air_velocity(&f, wind)[axis])
                    / step;
                assert!(
                    (h[VEL + v] - numeric).abs() < 1e-6,
                    "axis {axis}, v{v}: {} vs {numeric}",
                    h[VEL + v]
                );
            }
        }
    }

    /// A vehicle hovering in a 2 m/s wind from the west reads the drag of a 2 m/s airspeed
    /// towards the west; the wind it implies is the wind, whatever its heading and tilt.
    #[test]
    fn a_hover_in_wind_reads_the_wind() {
        for yaw in [0.0, 1.0, -2.5] {
            let f = filter(0.05, -0.08, yaw, [0.0, 0.0, 0.0]);
            let wind = [0.0, 2.0];
            let air = predicted_air_velocity(&f, wind);
            let force = QUAD.specific_force_xy(&air);
            let measured = QUAD.air_velocity_xy(force, air.z);
            let implied = wind_observation(&f, measured, [0.0, 0.0]);
            // With no wind held, body z's share is taken as still air: tilt leaves a little.
            assert!(
                (implied[0] - 0.0).abs() < 0.2 && (implied[1] - 2.0).abs() < 0.2,
                "yaw {yaw}: {implied:?}"
            );
            let implied = wind_observation(&f, measured, wind);
            assert!((implied[0]).abs() < 1e-9 && (implied[1] - 2.0).abs() < 1e-9, "yaw {yaw}: {implied:?}");
        }
    }

    /// Fusing the drag of a still vehicle in a known wind pulls a wrong velocity towards zero.
    #[test]
    fn fusing_drag_corrects_the_velocity() {
        let mut f = filter(0.0, 0.0, 0.6, [1.5, -1.0, 0.0]);
        let wind = [1.0, 0.0];
        let truth = Filter::aligned(State { vel_ned_m_s: Vector3::zeros(), ..f.state }, true);
        let measured = {
            let air = predicted_air_velocity(&truth, wind);
            let a = QUAD.air_velocity_xy(QUAD.specific_force_xy(&air), air.z);
            [a[0], a[1]]
        };
        let before = f.state.vel_ned_m_s.xy().norm();
        for _ in 0..20 {
            assert!(fuse_air_velocity(&mut f, measured, wind, 0.25));
        }
        let after = f.state.vel_ned_m_s.xy().norm();
        assert!(after < 0.1 * before, "{before} → {after}");
        let gate = air_velocity_innovations(&f, measured, wind, 0.25, 5.0);
        assert!(gate.iter().all(|i| i.test_ratio < 1.0), "{gate:?}");
    }
}
