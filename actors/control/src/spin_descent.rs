//! Flying a quad that lost a motor: give up yaw, let the vehicle spin, and steer only its
//! thrust axis with the three rotors left — the "relaxed hover" of Mueller & D'Andrea
//! ("Stability and control of a quadrocopter despite the complete loss of one, two, or three
//! propellers", ICRA 2014). PX4 only detects the loss and lands or terminates; a quad on PX4's
//! cascade tips over.
//!
//! Why the cascade cannot: with motor f gone, the torque about the diagonal axis through the
//! two motors beside it can come only from the motor opposite f, and that motor can only push
//! (one sign of torque). What the vehicle has instead is spin: the two motors beside f turn the
//! same way, their reaction torque is unbalanced, and the body spins up about its yaw axis
//! until rotational drag holds the rate. Spinning at r, the roll and pitch rates are coupled
//! gyroscopically (Euler: ṗ = τx/Ixx − (Izz − Iyy)/Ixx · q·r, and so for q), which turns the one
//! torque the pair can give both ways (about the axis through f and its opposite) round into
//! the other: both tilt axes become controllable, through the pair alone in the equilibrium.
//!
//! The law, a reduced-attitude control (the thrust axis only, heading free): `n`, the wanted
//! thrust axis (body down) seen in the body frame, moves as ṅ = n × ω. The body rates that
//! make each component of the error decay at `TILT_GAIN`, ṅxy = −k·nxy, are solved from that
//! kinematics with the measured spin r; the torque that brings the rates there at `RATE_GAIN`
//! (with the setpoint's own rate of change fed forward) is I·α + ω × Iω, the gyroscopic term
//! cancelled exactly. The torque and the collective are allocated to the three motors exactly
//! where they fit: the opposite motor takes the part of the torque along its own lever (only
//! when that part is a push, else it idles), the pair the rest and the thrust. At r = 0 (just
//! after the loss) the pull the opposite motor cannot give is missing until the spin builds up:
//! that is physics, and it sets the worst tilt of the recovery.
//!
//! Stateless and allocation-free: one call per 400 Hz iteration, on the measured state alone.

use kestrel_proto::frame_layout::FrameLayout;
use kestrel_proto::messages::MAX_MOTORS;
use nalgebra::{UnitQuaternion, Vector2, Vector3};
use thiserror::Error;

use crate::airframe::AirframeParams;

/// Rate (1/s) at which the thrust axis's error decays: slow next to the rate loop, which must
/// follow a setpoint that turns at the spin rate in the body frame.
pub const TILT_GAIN: f64 = 4.0;
/// Rate (1/s) at which the roll and pitch rates follow their setpoints: below the motors'
/// bandwidth (1/0.04 s) so that their lag does not destabilise the loop.
pub const RATE_GAIN: f64 = 20.0;
/// Largest angle (rad) between the wanted thrust axis and the vertical: 15°, so that position
/// and velocity demands never ask for a lean the three rotors cannot also hold the height at.
pub const MAX_TILT_RAD: f64 = 0.26;
/// Smallest vertical component of the wanted axis in the body frame the law divides by
/// (cos 60°): beyond that upset the rate setpoint and the collective saturate instead of
/// growing without bound.
const MIN_AXIS_DOWN: f64 = 0.5;

/// Input the law refuses rather than fly on.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum SpinInputError {
    #[error("attitude or body rate holds a non-finite value")]
    NonFiniteState,
    #[error("wanted thrust axis is not a finite, non-zero vector")]
    BadAxis,
    #[error("thrust {0} N is not finite and >= 0")]
    BadThrust(f64),
}

/// What one iteration asked for, for logs and tests.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpinOutput {
    /// Per-motor command 0..1 in the frame's order; the lost motor's is 0.
    pub motors: [f64; MAX_MOTORS],
    /// Torque demand (body FRD, N·m); yaw is never demanded.
    pub torque_n_m: Vector3<f64>,
    /// Collective thrust demand (N): the outer loops' over the cosine of the axis error.
    pub thrust_n: f64,
    /// Body-rate setpoint (FRD, rad/s); its yaw part is the measured spin.
    pub rates_rad_s: Vector3<f64>,
}

/// The law for one lost motor of a quad.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpinDescent {
    lost: usize,
    opposite: usize,
    /// The two motors beside the lost one.
    pair: [usize; 2],
    /// Roll and pitch torque (N·m) per N of thrust of the opposite motor and of `pair[0]`
    /// (`pair[1]`'s is the negative: it sits across the centre).
    lever_opposite_m: Vector2<f64>,
    lever_pair_m: Vector2<f64>,
    inertia_kg_m2: Vector3<f64>,
    max_thrust_per_motor_n: f64,
}

impl SpinDescent {
    /// The law for `airframe` with motor `lost` (0-based) gone; `None` unless the frame is a
    /// quad and the motor one of its four (a hexa or an octo keeps yaw on the others).
    pub fn new(airframe: &AirframeParams, lost: usize) -> Option<SpinDescent> {
        if airframe.frame != FrameLayout::QuadX {
            return None;
        }
        let mut positions = [Vector2::zeros(); 4];
        for (p, m) in positions.iter_mut().zip(airframe.frame.motors(airframe.arm_length_m)) {
            *p = m.position_frd_m.xy();
        }
        let at = *positions.get(lost)?;
        // The opposite motor is the one across the centre: the most negative dot product.
        let opposite = (0..4)
            .filter(|&i| i != lost)
            .min_by(|&a, &b| positions[a].dot(&at).total_cmp(&positions[b].dot(&at)))?;
        let mut pair = [0; 2];
        for (slot, i) in pair.iter_mut().zip((0..4).filter(|&i| i != lost && i != opposite)) {
            *slot = i;
        }
        // Thrust T up (along −z) at (x, y) gives roll −y·T and pitch x·T.
        let lever = |p: Vector2<f64>| Vector2::new(-p.y, p.x);
        let [i_x, i_y, i_z] = airframe.inertia_frd_kg_m2;
        Some(SpinDescent {
            lost,
            opposite,
            pair,
            lever_opposite_m: lever(positions[opposite]),
            lever_pair_m: lever(positions[pair[0]]),
            inertia_kg_m2: Vector3::new(i_x, i_y, i_z),
            max_thrust_per_motor_n: airframe.max_thrust_per_motor_n,
        })
    }

    /// The lost motor (0-based).
    pub fn lost(&self) -> usize {
        self.lost
    }

    /// The motor opposite the lost one (0-based), which idles in the spinning equilibrium.
    pub fn opposite(&self) -> usize {
        self.opposite
    }

    /// One iteration: attitude `q` (FRD → NED), body rate `omega` (FRD, rad/s), the thrust axis
    /// the outer loops want (body down, in NED; tilted at most [`MAX_TILT_RAD`] from vertical
    /// before use) and the collective they want along it (N).
    pub fn update(
        &self,
        q: &UnitQuaternion<f64>,
        omega: &Vector3<f64>,
        axis_wanted_ned: &Vector3<f64>,
        thrust_n: f64,
    ) -> Result<SpinOutput, SpinInputError> {
        if !(q.coords.iter().all(|c| c.is_finite()) && omega.iter().all(|w| w.is_finite())) {
            return Err(SpinInputError::NonFiniteState);
        }
        let norm = axis_wanted_ned.norm();
        if !(norm.is_finite() && norm > 0.0) {
            return Err(SpinInputError::BadAxis);
        }
        if !(thrust_n.is_finite() && thrust_n >= 0.0) {
            return Err(SpinInputError::BadThrust(thrust_n));
        }
        let n = q.inverse() * limit_tilt(&(axis_wanted_ned / norm));
        let (torque, rates) = self.demand(&n, omega);
        // The vertical part kept while the axis is off (to 60°): the spin-up that ends the upset
        // comes from the pair's reaction torque, which grows with their thrust.
        let collective = thrust_n / n.z.max(MIN_AXIS_DOWN);
        let (motors, delivered) = self.allocate(&torque, collective);
        Ok(SpinOutput {
            motors,
            torque_n_m: Vector3::new(delivered.x, delivered.y, 0.0),
            thrust_n: collective,
            rates_rad_s: rates,
        })
    }

    /// The roll/pitch torque (N·m) the law asks for with the wanted axis at `n` (unit, body
    /// FRD) and the body rate `omega`, and the body-rate setpoint it steers to.
    fn demand(&self, n: &Vector3<f64>, omega: &Vector3<f64>) -> (Vector2<f64>, Vector3<f64>) {
        let (k, kw) = (TILT_GAIN, RATE_GAIN);
        let (p, qr, r) = (omega.x, omega.y, omega.z);
        let nz = n.z.max(MIN_AXIS_DOWN);
        // ṅx = ny·r − nz·q and ṅy = nz·p − nx·r; asking ṅxy = −k·nxy gives the rates.
        let p_sp = (n.x * r - k * n.y) / nz;
        let q_sp = (n.y * r + k * n.x) / nz;
        // Their rate of change along the current motion (r held), fed forward.
        let n_dot = n.cross(omega);
        let p_sp_dot = (n_dot.x * r - k * n_dot.y) / nz;
        let q_sp_dot = (n_dot.y * r + k * n_dot.x) / nz;
        let alpha = Vector2::new(kw * (p_sp - p) + p_sp_dot, kw * (q_sp - qr) + q_sp_dot);
        let i = &self.inertia_kg_m2;
        // τ = I·ω̇ + ω × Iω, roll and pitch rows.
        let torque = Vector2::new(i.x * alpha.x + (i.z - i.y) * qr * r, i.y * alpha.y + (i.x - i.z) * r * p);
        (torque, Vector3::new(p_sp, q_sp, r))
    }

    /// Roll/pitch torque (N·m) and collective (N) to commands, and the torque they give. The
    /// opposite motor takes the part along its lever when it is a push; the pair the rest of
    /// the part along theirs (the part across it no motor left can give) and the collective,
    /// which moves to make room for that torque within 0..full on both.
    fn allocate(&self, torque: &Vector2<f64>, collective_n: f64) -> ([f64; MAX_MOTORS], Vector2<f64>) {
        let t_max = self.max_thrust_per_motor_n;
        let (lo, lp) = (&self.lever_opposite_m, &self.lever_pair_m);
        let opposite_n = (torque.dot(lo) / lo.norm_squared()).clamp(0.0, t_max);
        // T_a − T_b, and T_a + T_b.
        let difference = ((torque - lo * opposite_n).dot(lp) / lp.norm_squared()).clamp(-t_max, t_max);
        let spread = difference.abs();
        let sum = (collective_n - opposite_n).clamp(spread, 2.0 * t_max - spread);
        let (a, b) = (0.5 * (sum + difference), 0.5 * (sum - difference));
        let mut motors = [0.0; MAX_MOTORS];
        motors[self.opposite] = opposite_n / t_max;
        motors[self.pair[0]] = a / t_max;
        motors[self.pair[1]] = b / t_max;
        for m in &mut motors {
            *m = m.clamp(0.0, 1.0);
        }
        (motors, lo * opposite_n + lp * (a - b))
    }
}

/// `axis` (unit, NED), leaned back towards the vertical to at most [`MAX_TILT_RAD`].
fn limit_tilt(axis: &Vector3<f64>) -> Vector3<f64> {
    let horizontal = axis.xy().norm();
    let most = MAX_TILT_RAD.tan() * axis.z.max(0.0);
    if axis.z > 0.0 && horizontal <= most {
        return *axis;
    }
    // Too far over, or pointing up: the same heading of lean at the limit (straight down when
    // there is none).
    let lean = if horizontal > 0.0 { axis.xy() / horizontal } else { Vector2::zeros() };
    let (s, c) = MAX_TILT_RAD.sin_cos();
    let h = if horizontal > 0.0 { s } else { 0.0 };
    Vector3::new(lean.x * h, lean.y * h, if horizontal > 0.0 { c } else { 1.0 })
}

#[cfg(test)]
mod tests {
    use super::*;
    use kestrel_proto::units::GRAVITY_M_S2;
    use proptest::prelude::*;

    fn quad() -> AirframeParams {
        AirframeParams::default()
    }

    /// Roll/pitch torque (N·m), yaw torque (N·m) and thrust (N) of `motors`, from the motor
    /// table alone (not from the law's levers).
    fn wrench(motors: &[f64; MAX_MOTORS]) -> (Vector3<f64>, f64) {
        let a = quad();
        let mut torque = Vector3::zeros();
        let mut thrust = 0.0;
        for (m, &u) in a.frame.motors(a.arm_length_m).zip(motors) {
            let t = u * a.max_thrust_per_motor_n;
            let r = m.position_frd_m;
            torque += Vector3::new(-r.y * t, r.x * t, m.spin.yaw_sign() * a.torque_to_thrust_m * t);
            thrust += t;
        }
        (torque, thrust)
    }

    #[test]
    fn motor_one_lost_leaves_motor_two_opposite_and_three_four_beside() {
        // quad_x: 1 front-right, 2 rear-left, 3 front-left, 4 rear-right (1-based).
        let s = SpinDescent::new(&quad(), 0).expect("a quad");
        assert_eq!((s.lost(), s.opposite()), (0, 1));
        assert_eq!(SpinDescent::new(&quad(), 2).expect("a quad").opposite(), 3);
        assert!(SpinDescent::new(&quad(), 4).is_none());
        let hexa = AirframeParams { frame: FrameLayout::HexaX, ..quad() };
        assert!(SpinDescent::new(&hexa, 0).is_none());
    }

    #[test]
    fn relaxed_hover_equilibrium_is_the_pair_carrying_the_weight_and_the_opposite_idle() {
        // Level, spinning at 16 rad/s about down, axis wanted straight down, thrust = weight:
        // by hand, each of motors 3 and 4 carries m·g/2 = 7.355 N (command 0.6686), motor 2
        // none, and the reaction torque 2 · 0.016 m · 7.355 N = 0.2354 N·m is left over.
        let s = SpinDescent::new(&quad(), 0).expect("a quad");
        let weight = 1.5 * GRAVITY_M_S2;
        let out = s
            .update(&UnitQuaternion::identity(), &Vector3::new(0.0, 0.0, 16.0), &Vector3::z(), weight)
            .expect("valid");
        let half = weight / 2.0 / 11.0;
        assert!((out.motors[2] - half).abs() < 1e-12 && (out.motors[3] - half).abs() < 1e-12, "{out:?}");
        assert_eq!((out.motors[0], out.motors[1]), (0.0, 0.0));
        let (torque, thrust) = wrench(&out.motors);
        assert!((thrust - weight).abs() < 1e-9);
        assert!(torque.xy().norm() < 1e-12, "{torque}");
        assert!((torque.z.abs() - 2.0 * 0.016 * weight / 2.0).abs() < 1e-12, "{torque}");
    }

    #[test]
    fn torque_within_reach_is_delivered_exactly() {
        // A push along the opposite motor's lever and any torque along the pair's are met: the
        // motor table's wrench equals the demand the law reports.
        let s = SpinDescent::new(&quad(), 0).expect("a quad");
        let q = UnitQuaternion::from_euler_angles(0.05, -0.03, 1.0);
        let out = s.update(&q, &Vector3::new(0.4, -0.2, 12.0), &Vector3::z(), 14.0).expect("valid");
        let (torque, thrust) = wrench(&out.motors);
        assert!((torque.xy() - out.torque_n_m.xy()).norm() < 1e-12, "{torque} vs {}", out.torque_n_m);
        assert!((thrust - out.thrust_n).abs() < 1e-9);
        assert!(out.torque_n_m.xy().norm() > 0.01, "it corrects: {}", out.torque_n_m);
    }

    /// The law's derivation checked against Euler's equations and the kinematics ṅ = n × ω by
    /// finite differences: with its torque delivered whole, the loop about the spinning
    /// equilibrium has exactly the designed eigenvalues, −TILT_GAIN and −RATE_GAIN (each twice),
    /// whatever the spin rate (the gyroscopic coupling cancelled).
    #[test]
    fn the_linearised_loop_has_the_designed_eigenvalues_at_any_spin_rate() {
        let s = SpinDescent::new(&quad(), 0).expect("a quad");
        let inertia = Vector3::new(0.029, 0.029, 0.055);
        for r in [0.0, 3.0, 8.0, 16.0, -12.0] {
            // State: roll and pitch rate, and the first two components of the wanted axis
            // (here world down) in the body frame.
            let f = |x: &[f64; 4]| -> [f64; 4] {
                let omega = Vector3::new(x[0], x[1], r);
                let n = Vector3::new(x[2], x[3], 1.0).normalize();
                let (torque, _) = s.demand(&n, &omega);
                let torque = Vector3::new(torque.x, torque.y, 0.0);
                let alpha = (torque - omega.cross(&inertia.component_mul(&omega))).component_div(&inertia);
                let n_dot = n.cross(&omega);
                [alpha.x, alpha.y, n_dot.x, n_dot.y]
            };
            let h = 1e-6;
            let mut a = nalgebra::Matrix4::zeros();
            for j in 0..4 {
                let (mut plus, mut minus) = ([0.0; 4], [0.0; 4]);
                plus[j] = h;
                minus[j] = -h;
                let (fp, fm) = (f(&plus), f(&minus));
                for i in 0..4 {
                    a[(i, j)] = (fp[i] - fm[i]) / (2.0 * h);
                }
            }
            let mut eig: Vec<f64> = a.complex_eigenvalues().iter().map(|e| e.re).collect();
            let imag = a.complex_eigenvalues().iter().map(|e| e.im.abs()).fold(0.0, f64::max);
            eig.sort_by(f64::total_cmp);
            let want = [-RATE_GAIN, -RATE_GAIN, -TILT_GAIN, -TILT_GAIN];
            for (e, w) in eig.iter().zip(want) {
                assert!(
                    (e - w).abs() < 1e-3 && imag < 1e-3,
                    "r = {r}: eigenvalues {}",
                    a.complex_eigenvalues()
                );
            }
        }
    }

    #[test]
    fn a_lean_beyond_the_limit_is_brought_back_to_it() {
        let leaned = limit_tilt(&Vector3::new(1.0, 0.0, 1.0).normalize());
        assert!((leaned.angle(&Vector3::z()) - MAX_TILT_RAD).abs() < 1e-12, "{leaned}");
        assert!(leaned.x > 0.0 && leaned.y.abs() < 1e-15);
        assert_eq!(limit_tilt(&-Vector3::z()), Vector3::z());
        let small = Vector3::new(0.1, 0.0, 1.0).normalize();
        assert_eq!(limit_tilt(&small), small);
    }

    #[test]
    fn non_finite_input_is_refused() {
        let s = SpinDescent::new(&quad(), 0).expect("a quad");
        let q = UnitQuaternion::identity();
        let z = Vector3::z();
        assert_eq!(
            s.update(&q, &Vector3::new(f64::NAN, 0.0, 0.0), &z, 10.0),
            Err(SpinInputError::NonFiniteState)
        );
        assert_eq!(s.update(&q, &Vector3::zeros(), &Vector3::zeros(), 10.0), Err(SpinInputError::BadAxis));
        assert_eq!(
            s.update(&q, &Vector3::zeros(), &Vector3::new(0.0, f64::INFINITY, 1.0), 10.0),
            Err(SpinInputError::BadAxis)
        );
        assert!(matches!(s.update(&q, &Vector3::zeros(), &z, f64::NAN), Err(SpinInputError::BadThrust(_))));
        assert!(matches!(s.update(&q, &Vector3::zeros(), &z, -1.0), Err(SpinInputError::BadThrust(_))));
    }

    proptest! {
        /// Whatever the finite state and demand: every command finite and in 0..1, the lost
        /// motor's 0, and no yaw torque asked for.
        #[test]
        fn commands_stay_in_range_for_any_finite_state(
            lost in 0usize..4,
            quat in prop::array::uniform4(-1.0f64..1.0),
            omega in prop::array::uniform3(-60.0f64..60.0),
            axis in prop::array::uniform3(-1.0f64..1.0),
            thrust in 0.0f64..100.0,
        ) {
            let s = SpinDescent::new(&quad(), lost).expect("a quad");
            let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(quat[0], quat[1], quat[2], quat[3]));
            prop_assume!(q.coords.iter().all(|c| c.is_finite()) && Vector3::from(axis).norm() > 1e-6);
            let out = s.update(&q, &Vector3::from(omega), &Vector3::from(axis), thrust).expect("finite input");
            prop_assert!(out.motors.iter().all(|m| m.is_finite() && (0.0..=1.0).contains(m)), "{:?}", out.motors);
            prop_assert_eq!(out.motors[lost], 0.0);
            prop_assert_eq!(out.torque_n_m.z, 0.0);
        }
    }
}
