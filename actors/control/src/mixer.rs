//! Torque and collective thrust → normalised motor commands, with saturation handling that
//! keeps attitude authority, and re-allocation around a failed motor.
//!
//! The allocation is the pseudo-inverse of the frame's effectiveness matrix (rows: roll, pitch,
//! yaw torque and collective thrust per unit command), so it works for quad-, hexa- and octo-X
//! alike. Commands map linearly to thrust (the simulator's and PX4's `THR_MDL_FAC = 1` model).
//!
//! When the demand does not fit in 0..1 the mixer gives way in PX4's order (its
//! `MultirotorMixer` without air-mode on yaw): roll and pitch are kept, scaled down only when
//! they alone do not fit (keeping their ratio and sign); then yaw is added and scaled down as
//! far as needed; the collective thrust is what moves to make room for both, so a near-idle or
//! full-throttle demand still gets its roll and pitch torque.
//!
//! A failed motor is removed from the allocation as PX4 does with `CA_FAILURE_MODE = 1`: its
//! column of the effectiveness is zeroed and the pseudo-inverse recomputed. If the remaining
//! motors still span all four axes (hexa, octo) the demand is met over them; if not (a quad
//! left with three) yaw is given up and roll, pitch and thrust are allocated exactly — the
//! vehicle spins, but stays upright and can land. Every case is computed when the mixer is
//! built, so switching to one in flight is a copy: the 400 Hz loop never allocates.

use kestrel_proto::messages::MAX_MOTORS;
use nalgebra::{DMatrix, Vector3};

use crate::airframe::AirframeParams;

/// Which demands the mixer could not meet, for the controllers' anti-windup.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Saturation {
    /// Roll and pitch torque were scaled down.
    pub roll_pitch: bool,
    /// Yaw torque was scaled down (or is not allocated at all after a motor failure).
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

/// One allocation: the pseudo-inverse of the effectiveness over the motors in use.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Allocation {
    /// Command of motor i per N·m of roll, pitch, yaw torque.
    torque_to_command: [[f64; 3]; MAX_MOTORS],
    /// Command of motor i per N of collective thrust.
    thrust_to_command: [f64; MAX_MOTORS],
    /// Whether yaw torque is allocated (false: the remaining motors cannot give it).
    yaw: bool,
}

/// The allocation for one frame, healthy and with each single motor failed.
#[derive(Clone, Debug, PartialEq)]
pub struct Mixer {
    motor_count: usize,
    /// Index 0: every motor; index i + 1: motor i (0-based) removed.
    allocations: [Allocation; MAX_MOTORS + 1],
    /// The allocation in use.
    active: usize,
    /// Collective thrust (N) of every healthy motor at command 1.
    full_thrust_n: f64,
}

/// Bisection steps of the roll/pitch and yaw scales: 2⁻³⁰ of the demand is far below motor noise.
const BISECTION_STEPS: u32 = 30;

/// Singular values below this (relative to the largest) count as zero: the rank test.
const RANK_TOLERANCE: f64 = 1e-9;

/// The effectiveness of `airframe`'s motors (rows roll, pitch, yaw torque in N·m and
/// collective thrust in N per unit command; column i motor i), with motor `failed`'s column
/// zeroed.
fn effectiveness(airframe: &AirframeParams, failed: Option<usize>) -> DMatrix<f64> {
    let rotors: Vec<_> = airframe.frame.motors(airframe.arm_length_m).collect();
    let t_max = airframe.max_thrust_per_motor_n;
    // Thrust along body up is -z; torque = r × (0, 0, -T) = (-y·T, x·T, 0) plus the
    // propeller's reaction torque about down.
    DMatrix::from_fn(4, rotors.len(), |row, i| {
        if Some(i) == failed {
            return 0.0;
        }
        let r = &rotors[i].position_frd_m;
        t_max
            * match row {
                0 => -r.y,
                1 => r.x,
                2 => rotors[i].spin.yaw_sign() * airframe.torque_to_thrust_m,
                _ => 1.0,
            }
    })
}

/// Rank of `m` by its singular values.
fn rank(m: &DMatrix<f64>) -> usize {
    let sv = m.clone().svd(false, false).singular_values;
    let largest = sv.max();
    sv.iter().filter(|&&s| s > RANK_TOLERANCE * largest).count()
}

impl Allocation {
    fn new(airframe: &AirframeParams, failed: Option<usize>) -> Allocation {
        let full = effectiveness(airframe, failed);
        let yaw = rank(&full) == 4;
        // Without yaw authority, allocate roll, pitch and thrust only (rows 0, 1, 3).
        let used = if yaw { full } else { full.select_rows(&[0, 1, 3]) };
        let mut out = Allocation {
            torque_to_command: [[0.0; 3]; MAX_MOTORS],
            thrust_to_command: [0.0; MAX_MOTORS],
            yaw,
        };
        // A symmetric frame's effectiveness, less at most one motor, has full row rank over
        // the rows used, so the pseudo-inverse exists; should it ever fail, an all-zero
        // allocation commands nothing.
        if let Ok(pinv) = used.pseudo_inverse(1e-12) {
            for i in 0..pinv.nrows() {
                let (roll, pitch) = (pinv[(i, 0)], pinv[(i, 1)]);
                let (yaw_k, thrust) = if yaw { (pinv[(i, 2)], pinv[(i, 3)]) } else { (0.0, pinv[(i, 2)]) };
                out.torque_to_command[i] = [roll, pitch, yaw_k];
                out.thrust_to_command[i] = thrust;
            }
        }
        // Its row of the pseudo-inverse is zero up to rounding: make it exactly so.
        if let Some(f) = failed {
            out.torque_to_command[f] = [0.0; 3];
            out.thrust_to_command[f] = 0.0;
        }
        out
    }
}

impl Mixer {
    /// The mixer for a validated airframe, every single-motor failure precomputed.
    pub fn new(airframe: &AirframeParams) -> Mixer {
        let n = airframe.frame.motor_count();
        let healthy = Allocation::new(airframe, None);
        let mut allocations = [healthy; MAX_MOTORS + 1];
        for (i, a) in allocations.iter_mut().enumerate().skip(1).take(n) {
            *a = Allocation::new(airframe, Some(i - 1));
        }
        Mixer {
            motor_count: n,
            allocations,
            active: 0,
            full_thrust_n: n as f64 * airframe.max_thrust_per_motor_n,
        }
    }

    /// Number of motors this mixer drives.
    pub fn motor_count(&self) -> usize {
        self.motor_count
    }

    /// Collective thrust (N) that one unit of every motor's command gives on the healthy frame.
    pub fn full_thrust_n(&self) -> f64 {
        self.full_thrust_n
    }

    /// Allocates around motor `failed` (0-based; `None`: every motor) from the next mix on. A
    /// motor outside the frame is refused and the allocation kept.
    pub fn set_failed_motor(&mut self, failed: Option<usize>) -> Result<(), usize> {
        match failed {
            None => self.active = 0,
            Some(i) if i < self.motor_count => self.active = i + 1,
            Some(i) => return Err(i),
        }
        Ok(())
    }

    /// The motor the allocation leaves out, if any.
    pub fn failed_motor(&self) -> Option<usize> {
        self.active.checked_sub(1)
    }

    /// Whether yaw torque is allocated (false on a quad that lost a motor).
    pub fn has_yaw_authority(&self) -> bool {
        self.allocations[self.active].yaw
    }

    /// Mixes a torque demand (body FRD, N·m) and a collective thrust demand (N, upwards along
    /// body −z). Non-finite demands count as zero.
    pub fn mix(&self, torque_frd_n_m: &Vector3<f64>, thrust_n: f64) -> MixerOutput {
        let n = self.motor_count;
        let a = &self.allocations[self.active];
        let clean = |v: f64| if v.is_finite() { v } else { 0.0 };
        let (tx, ty, tz) = (clean(torque_frd_n_m.x), clean(torque_frd_n_m.y), clean(torque_frd_n_m.z));
        let mut roll_pitch = [0.0; MAX_MOTORS];
        let mut yaw = [0.0; MAX_MOTORS];
        for i in 0..n {
            let k = &a.torque_to_command[i];
            roll_pitch[i] = k[0] * tx + k[1] * ty;
            yaw[i] = k[2];
        }
        let split = Split {
            rp: &roll_pitch[..n],
            yaw: &yaw[..n],
            thrust: &a.thrust_to_command[..n],
            yaw_bound_n_m: self.yaw_bound_n_m(),
            free_yaw: self.active != 0,
        };
        let mut saturation = Saturation { yaw: !a.yaw, ..Saturation::default() };
        let rp_scale = if split.best_yaw(1.0).1 >= 0.0 {
            1.0
        } else {
            saturation.roll_pitch = true;
            bisect(|s| split.best_yaw(s).1 >= 0.0)
        };
        // The yaw torque nearest the demand that fits: the demand itself, or the end of the
        // segment from the best-fitting yaw towards it where it stops fitting.
        let (best, _) = split.best_yaw(rp_scale);
        let yaw_n_m = if !a.yaw {
            0.0
        } else if split.margin(rp_scale, tz) >= 0.0 {
            tz
        } else {
            saturation.yaw = true;
            best + (tz - best) * bisect(|k| split.margin(rp_scale, best + (tz - best) * k) >= 0.0)
        };
        let (lo, hi) = split.thrust_range(rp_scale, yaw_n_m);
        let wanted = clean(thrust_n).max(0.0);
        let collective = wanted.clamp(lo, hi.max(lo));
        saturation.thrust_raised = collective > wanted + 1e-9;
        saturation.thrust_lowered = collective < wanted - 1e-9;
        let mut motors = [0.0; MAX_MOTORS];
        for i in 0..n {
            let u = collective * a.thrust_to_command[i] + rp_scale * roll_pitch[i] + yaw_n_m * yaw[i];
            motors[i] = u.clamp(0.0, 1.0);
        }
        MixerOutput { motors, saturation }
    }

    /// More yaw torque than every motor's drag together could give (N·m): the search range.
    fn yaw_bound_n_m(&self) -> f64 {
        let a = &self.allocations[self.active];
        let least = a.torque_to_command[..self.motor_count]
            .iter()
            .map(|k| k[2].abs())
            .filter(|k| *k > NO_SHARE)
            .fold(f64::INFINITY, f64::min);
        if least.is_finite() { self.motor_count as f64 / least } else { 0.0 }
    }
}

/// One demand split per motor: roll/pitch commands, and the commands per N·m of yaw and per N
/// of thrust.
struct Split<'a> {
    rp: &'a [f64],
    yaw: &'a [f64],
    thrust: &'a [f64],
    yaw_bound_n_m: f64,
    /// Whether yaw torque of either sign may be produced to make roll and pitch fit: only
    /// around a failed motor, whose opposite number then carries no thrust in hover and must
    /// not be asked for less than none. A healthy frame never yaws against the demand.
    free_yaw: bool,
}

/// A motor with less share than this (command per N or N·m) is not moved by that demand.
const NO_SHARE: f64 = 1e-12;

/// Steps of the search for the best-fitting yaw torque (golden section): the range shrinks by
/// 0.618 a step, to 10⁻¹⁰ of it.
const GOLDEN_STEPS: u32 = 48;

impl Split<'_> {
    /// The collective thrusts (N) that keep every motor carrying thrust in 0..1 with roll/pitch
    /// scaled by `s` and `yaw_n_m` of yaw, as (lowest, highest); empty (lowest > highest) when
    /// none does.
    fn thrust_range(&self, s: f64, yaw_n_m: f64) -> (f64, f64) {
        let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
        for ((r, y), &t) in self.rp.iter().zip(self.yaw).zip(self.thrust) {
            if t > NO_SHARE {
                let v = s * r + yaw_n_m * y;
                lo = lo.max(-v / t);
                hi = hi.min((1.0 - v) / t);
            }
        }
        (lo, hi)
    }

    /// How far (in command) the demand with roll/pitch scaled by `s` and `yaw_n_m` of yaw is
    /// inside the motors' range for the best collective: ≥ 0 when it fits. A motor without a
    /// thrust share (the one opposite a failed motor: with the frame balanced on the others it
    /// carries none in hover) is bound by its own range through roll, pitch and yaw; one with
    /// neither a thrust nor a yaw share (a quad's, once yaw is given up) is moved by roll and
    /// pitch alone, in one direction only — the physics of three rotors — and left to its clamp.
    /// Concave in `yaw_n_m`: the feasible yaw torques are an interval.
    fn margin(&self, s: f64, yaw_n_m: f64) -> f64 {
        let (lo, hi) = self.thrust_range(s, yaw_n_m);
        let mut margin =
            if lo.is_finite() && hi.is_finite() { (hi - lo) * self.least_thrust_share() } else { 0.0 };
        for ((r, y), &t) in self.rp.iter().zip(self.yaw).zip(self.thrust) {
            if t <= NO_SHARE && y.abs() > NO_SHARE {
                let v = s * r + yaw_n_m * y;
                margin = margin.min(v).min(1.0 - v);
            }
        }
        margin
    }

    /// The smallest positive thrust share: turns the collective's spare range (N) into command.
    fn least_thrust_share(&self) -> f64 {
        self.thrust.iter().copied().filter(|t| *t > NO_SHARE).fold(f64::INFINITY, f64::min)
    }

    /// The yaw torque that fits best with roll/pitch scaled by `s`, and its margin.
    fn best_yaw(&self, s: f64) -> (f64, f64) {
        if self.yaw.iter().all(|y| y.abs() <= NO_SHARE) {
            return (0.0, self.margin(s, 0.0));
        }
        if !self.free_yaw || self.margin(s, 0.0) >= 0.0 {
            return (0.0, self.margin(s, 0.0));
        }
        let phi = 0.5 * (5f64.sqrt() - 1.0);
        let (mut a, mut b) = (-self.yaw_bound_n_m, self.yaw_bound_n_m);
        for _ in 0..GOLDEN_STEPS {
            let c = b - phi * (b - a);
            let d = a + phi * (b - a);
            if self.margin(s, c) >= self.margin(s, d) { b = d } else { a = c }
        }
        let z = 0.5 * (a + b);
        (z, self.margin(s, z))
    }
}

/// The largest x in 0..1 with `fits(x)`, given `fits(0)`.
fn bisect(fits: impl Fn(f64) -> bool) -> f64 {
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..BISECTION_STEPS {
        let mid = 0.5 * (lo + hi);
        if fits(mid) { lo = mid } else { hi = mid }
    }
    lo
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
