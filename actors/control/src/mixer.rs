//! Torque and collective thrust → normalised motor commands, with saturation handling that
//! keeps attitude authority.
//!
//! The allocation is the pseudo-inverse of the frame's effectiveness matrix (rows: roll, pitch,
//! yaw torque and collective thrust per unit command), so it works for quad-, hexa- and octo-X
//! alike. Commands map linearly to thrust (the simulator's and PX4's `THR_MDL_FAC = 1` model).
//!
//! When the demand does not fit in 0..1 the mixer gives way in PX4's order (its
//! `MultirotorMixer` without air-mode on yaw): roll and pitch are kept, scaled down only when
//! their spread alone exceeds the range (keeping their ratio and sign); then yaw is added and
//! scaled down as far as needed; the collective thrust is what moves to make room for both, so
//! a near-idle or full-throttle demand still gets its roll and pitch torque.

use kestrel_proto::messages::MAX_MOTORS;
use nalgebra::{DMatrix, Vector3};

use crate::airframe::AirframeParams;

/// Which demands the mixer could not meet, for the controllers' anti-windup.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Saturation {
    /// Roll and pitch torque were scaled down.
    pub roll_pitch: bool,
    /// Yaw torque was scaled down.
    pub yaw: bool,
    /// Thrust was raised above the demand to make room for torque.
    pub thrust_raised: bool,
    /// Thrust was lowered below the demand (to make room, or because it exceeded the maximum).
    pub thrust_lowered: bool,
}

/// Motor commands and what had to give.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MixerOutput {
    /// Per-motor command 0..1 in the frame's motor order; unused entries are 0.
    pub motors: [f64; MAX_MOTORS],
    pub saturation: Saturation,
}

/// The allocation for one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Mixer {
    motor_count: usize,
    /// Command of motor i per N·m of roll, pitch, yaw torque.
    torque_to_command: [[f64; 3]; MAX_MOTORS],
    /// Command of every motor per N of collective thrust.
    thrust_to_command: f64,
}

/// Iterations of the yaw-scale bisection: 2⁻²⁴ of the yaw demand is far below motor noise.
const YAW_BISECTION_STEPS: u32 = 24;

impl Mixer {
    /// The mixer for a validated airframe.
    pub fn new(airframe: &AirframeParams) -> Mixer {
        let rotors: Vec<_> = airframe.frame.motors(airframe.arm_length_m).collect();
        let n = rotors.len();
        let t_max = airframe.max_thrust_per_motor_n;
        // Thrust along body up is -z; torque = r × (0, 0, -T) = (-y·T, x·T, 0) plus the
        // propeller's reaction torque about down.
        let effectiveness = DMatrix::from_fn(4, n, |row, i| {
            let r = &rotors[i].position_frd_m;
            t_max
                * match row {
                    0 => -r.y,
                    1 => r.x,
                    2 => rotors[i].spin.yaw_sign() * airframe.torque_to_thrust_m,
                    _ => 1.0,
                }
        });
        let mut torque_to_command = [[0.0; 3]; MAX_MOTORS];
        let thrust_to_command = 1.0 / (n as f64 * t_max);
        // A symmetric frame's effectiveness has full row rank, so the pseudo-inverse exists;
        // should it ever fail, an all-zero allocation leaves only the collective thrust.
        if let Ok(pinv) = effectiveness.pseudo_inverse(1e-12) {
            for (i, row) in torque_to_command.iter_mut().enumerate().take(n) {
                *row = [pinv[(i, 0)], pinv[(i, 1)], pinv[(i, 2)]];
            }
        }
        Mixer { motor_count: n, torque_to_command, thrust_to_command }
    }

    /// Number of motors this mixer drives.
    pub fn motor_count(&self) -> usize {
        self.motor_count
    }

    /// Collective thrust (N) that one unit of every motor's command gives.
    pub fn full_thrust_n(&self) -> f64 {
        1.0 / self.thrust_to_command
    }

    /// Mixes a torque demand (body FRD, N·m) and a collective thrust demand (N, upwards along
    /// body −z). Non-finite demands count as zero.
    pub fn mix(&self, torque_frd_n_m: &Vector3<f64>, thrust_n: f64) -> MixerOutput {
        let n = self.motor_count;
        let clean = |v: f64| if v.is_finite() { v } else { 0.0 };
        let (tx, ty, tz) = (clean(torque_frd_n_m.x), clean(torque_frd_n_m.y), clean(torque_frd_n_m.z));
        let mut roll_pitch = [0.0; MAX_MOTORS];
        let mut yaw = [0.0; MAX_MOTORS];
        for i in 0..n {
            let k = &self.torque_to_command[i];
            roll_pitch[i] = k[0] * tx + k[1] * ty;
            yaw[i] = k[2] * tz;
        }
        let mut saturation = Saturation::default();
        let rp_spread = spread(&roll_pitch[..n], &yaw[..n], 0.0);
        if rp_spread > 1.0 {
            roll_pitch[..n].iter_mut().for_each(|c| *c /= rp_spread);
            saturation.roll_pitch = true;
        }
        let yaw_scale = if spread(&roll_pitch[..n], &yaw[..n], 1.0) <= 1.0 {
            1.0
        } else {
            saturation.yaw = true;
            let (mut lo, mut hi) = (0.0, 1.0);
            for _ in 0..YAW_BISECTION_STEPS {
                let mid = 0.5 * (lo + hi);
                if spread(&roll_pitch[..n], &yaw[..n], mid) <= 1.0 { lo = mid } else { hi = mid }
            }
            lo
        };
        let (lo, hi) = bounds(&roll_pitch[..n], &yaw[..n], yaw_scale);
        let wanted = clean(thrust_n).max(0.0) * self.thrust_to_command;
        let collective = wanted.clamp(-lo, (1.0 - hi).max(-lo));
        saturation.thrust_raised = collective > wanted + 1e-12;
        saturation.thrust_lowered = collective < wanted - 1e-12;
        let mut motors = [0.0; MAX_MOTORS];
        for i in 0..n {
            motors[i] = (collective + roll_pitch[i] + yaw_scale * yaw[i]).clamp(0.0, 1.0);
        }
        MixerOutput { motors, saturation }
    }
}

/// (min, max) over motors of `rp + k·yaw`.
fn bounds(rp: &[f64], yaw: &[f64], k: f64) -> (f64, f64) {
    rp.iter().zip(yaw).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (r, y)| {
        let v = r + k * y;
        (lo.min(v), hi.max(v))
    })
}

fn spread(rp: &[f64], yaw: &[f64], k: f64) -> f64 {
    let (lo, hi) = bounds(rp, yaw, k);
    if lo.is_finite() { hi - lo } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kestrel_proto::frame_layout::FrameLayout;

    /// Torque and thrust the motors actually produce, by the same physics as the simulator.
    fn wrench(airframe: &AirframeParams, motors: &[f64; MAX_MOTORS]) -> (Vector3<f64>, f64) {
        let mut torque = Vector3::zeros();
        let mut thrust = 0.0;
        for (m, &u) in airframe.frame.motors(airframe.arm_length_m).zip(motors) {
            let (r, t) = (m.position_frd_m, u * airframe.max_thrust_per_motor_n);
            torque += Vector3::new(-r.y * t, r.x * t, m.spin.yaw_sign() * airframe.torque_to_thrust_m * t);
            thrust += t;
        }
        (torque, thrust)
    }

    #[test]
    fn unsaturated_demands_are_met_exactly_on_every_frame() {
        for frame in [FrameLayout::QuadX, FrameLayout::HexaX, FrameLayout::OctoX] {
            let airframe = AirframeParams { frame, ..AirframeParams::default() };
            let mixer = Mixer::new(&airframe);
            let demand = Vector3::new(0.3, -0.2, 0.05);
            let out = mixer.mix(&demand, 15.0);
            let (torque, thrust) = wrench(&airframe, &out.motors);
            assert!((torque - demand).norm() < 1e-9, "{frame:?} {torque}");
            assert!((thrust - 15.0).abs() < 1e-9, "{frame:?} {thrust}");
            assert_eq!(out.saturation, Saturation::default());
        }
    }

    #[test]
    fn quad_x_roll_right_speeds_up_the_left_motors() {
        let mixer = Mixer::new(&AirframeParams::default());
        let out = mixer.mix(&Vector3::new(0.5, 0.0, 0.0), 15.0);
        // Motors 2 (rear-left) and 3 (front-left) push the left side up: roll right.
        assert!(out.motors[1] > out.motors[0] && out.motors[2] > out.motors[3], "{:?}", out.motors);
    }

    #[test]
    fn yaw_gives_way_before_roll_and_thrust_moves_to_make_room() {
        let airframe = AirframeParams::default();
        let mixer = Mixer::new(&airframe);
        let demand = Vector3::new(1.5, 0.0, 2.0);
        let out = mixer.mix(&demand, 1.0);
        let (torque, _) = wrench(&airframe, &out.motors);
        assert!((torque.x - 1.5).abs() < 1e-6, "roll kept: {torque}");
        assert!(torque.z < 2.0 && torque.z > 0.0, "yaw reduced, sign kept: {torque}");
        assert!(out.saturation.yaw && out.saturation.thrust_raised && !out.saturation.roll_pitch);
    }

    #[test]
    fn non_finite_demands_stop_nothing_and_produce_finite_commands() {
        let mixer = Mixer::new(&AirframeParams::default());
        let out = mixer.mix(&Vector3::new(f64::NAN, 0.0, f64::INFINITY), f64::NAN);
        assert!(out.motors.iter().all(|m| m.is_finite() && (0.0..=1.0).contains(m)));
    }
}
