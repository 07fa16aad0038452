//! Motors and propellers: command → commanded speed → first-order lag → thrust and torque.
//!
//! The command map is *linear in thrust*: a command `u` in 0..1 asks for the speed
//! `ω_max·√u`, so steady thrust is `u·k_f·ω_max²`. That is what a mixer assumes when it adds
//! thrust and torque demands linearly (PX4's `THR_MDL_FAC = 1`), and it makes the hover command
//! a closed form. Supply voltage does not change the map: the ESCs are assumed to hold speed.
//!
//! Between command and speed lie the pulse and the ESC, as on a PWM vehicle: the command is
//! mapped onto the output's pulse range (the live `SERVOn_MIN`/`SERVOn_MAX`,
//! `kestrel_proto::esc::EscRanges`), and each ESC reads that pulse against its *own* range
//! (`esc_range_us`, from the vehicle file): throttle `(pulse − start)/(full − start)`, clamped to
//! 0..1. Where the two ranges are equal (the default, 1000..2000 µs both) the throttle is the
//! command itself, exactly, so a vehicle without `esc_range_us` flies as it always did. An ESC
//! range calibration drives the pulses directly ([`Motors::command_pulses`]) with the propellers
//! off ([`Motors::set_props_on`]): the motors turn, push nothing, and report their speed.

use kestrel_proto::esc::{EscRanges, MIN_RANGE_US, SAFE_PULSE_MAX_US, SAFE_PULSE_MIN_US};
use kestrel_proto::messages::{ActuatorOutputs, MAX_MOTORS};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, positive};
use kestrel_proto::frame_layout::{FrameLayout, MotorGeometry};

/// One motor-propeller pair; every motor of a frame is the same.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MotorParams {
    /// `k_f` in thrust = k_f·ω² (N per (rad/s)²).
    pub thrust_coefficient_n_per_rad2_s2: f64,
    /// `k_m` in the propeller's drag torque = k_m·ω² (N·m per (rad/s)²); its reaction yaws the body.
    pub torque_coefficient_n_m_per_rad2_s2: f64,
    /// Speed at command 1 (rad/s).
    pub max_speed_rad_s: f64,
    /// First-order lag from commanded to actual speed (s).
    pub time_constant_s: f64,
    /// Shaft power over electrical power, 0..1; sets the battery current.
    pub efficiency: f64,
    /// Each motor's ESC range `[start, full]` (µs), in the frame's motor order: the pulse at
    /// which it starts to turn and the one from which it turns no faster. Empty (the default) =
    /// every ESC on 1000..2000 µs, the nominal range the outputs assume until calibrated; else
    /// one pair per motor, `800 ≤ start`, `start + 100 ≤ full ≤ 2200`.
    pub esc_range_us: Vec<[f64; 2]>,
}

impl Default for MotorParams {
    /// An 850 KV motor with a 10×4.5 propeller on 4S (the thesis's airframe): about 11 N of
    /// thrust at 1000 rad/s (9 500 rpm), torque/thrust ratio 0.016 m.
    fn default() -> MotorParams {
        MotorParams {
            thrust_coefficient_n_per_rad2_s2: 1.1e-5,
            torque_coefficient_n_m_per_rad2_s2: 1.76e-7,
            max_speed_rad_s: 1000.0,
            time_constant_s: 0.04,
            efficiency: 0.75,
            esc_range_us: Vec::new(),
        }
    }
}

impl MotorParams {
    pub(crate) fn validate(&self) -> Result<(), InvalidParam> {
        positive("thrust_coefficient_n_per_rad2_s2", self.thrust_coefficient_n_per_rad2_s2)?;
        positive("torque_coefficient_n_m_per_rad2_s2", self.torque_coefficient_n_m_per_rad2_s2)?;
        positive("max_speed_rad_s", self.max_speed_rad_s)?;
        positive("time_constant_s", self.time_constant_s)?;
        positive("efficiency", self.efficiency)?;
        if self.efficiency > 1.0 {
            return Err(InvalidParam::new("efficiency", "must not exceed 1"));
        }
        for (i, &[start, full]) in self.esc_range_us.iter().enumerate() {
            let ok = start.is_finite()
                && full.is_finite()
                && start >= SAFE_PULSE_MIN_US
                && full <= SAFE_PULSE_MAX_US
                && full - start >= MIN_RANGE_US;
            if !ok {
                return Err(InvalidParam::new(
                    format!("esc_range_us[{i}]"),
                    format!(
                        "[{start}, {full}] must be finite with {SAFE_PULSE_MIN_US} ≤ start, start + {MIN_RANGE_US} ≤ full ≤ {SAFE_PULSE_MAX_US} µs"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Checks `esc_range_us` holds none or one range per motor of a frame of `motors`.
    pub(crate) fn validate_for(&self, motors: usize) -> Result<(), InvalidParam> {
        if !self.esc_range_us.is_empty() && self.esc_range_us.len() != motors {
            return Err(InvalidParam::new(
                "esc_range_us",
                format!("{} ranges for {motors} motors: give one per motor or none", self.esc_range_us.len()),
            ));
        }
        Ok(())
    }

    /// ESC `motor`'s `[start, full]` (µs).
    pub fn esc_range(&self, motor: usize) -> [f64; 2] {
        self.esc_range_us.get(motor).copied().unwrap_or([1000.0, 2000.0])
    }

    /// Thrust of one motor at full command (N).
    pub fn max_thrust_n(&self) -> f64 {
        self.thrust_coefficient_n_per_rad2_s2 * self.max_speed_rad_s.powi(2)
    }

    /// The steady speed a command asks for (rad/s); NaN and out-of-range commands clamp to 0..1.
    pub fn commanded_speed_rad_s(&self, command: f64) -> f64 {
        let u = if command.is_nan() { 0.0 } else { command.clamp(0.0, 1.0) };
        self.max_speed_rad_s * u.sqrt()
    }
}

/// What the active faults do to the motors (see [`FaultKind`](crate::faults::FaultKind)).
#[derive(Clone, Debug, PartialEq)]
pub struct MotorFaults {
    /// Per motor in mixer order: thrust and drag torque (and so shaft power) at a given speed
    /// are `k_f·k·ω²` and `k_m·k·ω²`; 1 healthy, 0 lost (`motor_lost`), `thrust` for
    /// `motor_weak`.
    pub thrust_scale: [f64; MAX_MOTORS],
}

impl Default for MotorFaults {
    fn default() -> MotorFaults {
        MotorFaults { thrust_scale: [1.0; MAX_MOTORS] }
    }
}

/// The motors of one frame and their current speeds.
#[derive(Clone, Debug)]
pub(crate) struct Motors {
    params: MotorParams,
    geometry: Vec<MotorGeometry>,
    speed_rad_s: [f64; MAX_MOTORS],
    target_rad_s: [f64; MAX_MOTORS],
    /// Thrust and torque scale of each motor, from the faults active this tick.
    scale: [f64; MAX_MOTORS],
    /// Each ESC's own `[start, full]` (µs).
    esc_us: [[f64; 2]; MAX_MOTORS],
    /// The outputs' command → pulse map.
    outputs: EscRanges,
    /// Propellers on: off (an ESC calibration) the motors turn and push nothing.
    props_on: bool,
}

impl Motors {
    pub(crate) fn new(params: &MotorParams, layout: FrameLayout, arm_length_m: f64) -> Motors {
        Motors {
            params: params.clone(),
            geometry: layout.motors(arm_length_m).collect(),
            speed_rad_s: [0.0; MAX_MOTORS],
            target_rad_s: [0.0; MAX_MOTORS],
            scale: [1.0; MAX_MOTORS],
            esc_us: std::array::from_fn(|i| params.esc_range(i)),
            outputs: EscRanges::default(),
            props_on: true,
        }
    }

    /// The outputs' command → pulse map from now on (the next command uses it).
    pub(crate) fn set_output_ranges(&mut self, ranges: &EscRanges) {
        self.outputs = *ranges;
    }

    /// Propellers on or off.
    pub(crate) fn set_props_on(&mut self, on: bool) {
        self.props_on = on;
    }

    /// The speed ESC `i` holds for `pulse_us` (rad/s).
    fn speed_for_pulse(&self, i: usize, pulse_us: f64) -> f64 {
        let [start, full] = self.esc_us[i];
        self.params.commanded_speed_rad_s((pulse_us - start) / (full - start))
    }

    /// Drives every motor at a pulse (µs) of its own, the mixer bypassed (ESC calibration).
    pub(crate) fn command_pulses(&mut self, pulses_us: &[f64; MAX_MOTORS]) {
        self.target_rad_s = std::array::from_fn(|i| self.speed_for_pulse(i, pulses_us[i]));
    }

    /// Applies the motor faults active from now on.
    pub(crate) fn set_faults(&mut self, faults: &MotorFaults) {
        self.scale = faults.thrust_scale;
    }

    /// Takes new commands; a disarmed output stops every motor.
    pub(crate) fn command(&mut self, outputs: &ActuatorOutputs) {
        for (i, &u) in outputs.motors.iter().enumerate() {
            let range = self.outputs.outputs[i];
            self.target_rad_s[i] = if !outputs.armed {
                0.0
            } else if [range.min_us, range.max_us] == self.esc_us[i] {
                // The ESC reads the pulse as the output meant it: the throttle is the command.
                self.params.commanded_speed_rad_s(u)
            } else {
                self.speed_for_pulse(i, self.outputs.pulse_us(i, u))
            };
        }
    }

    /// Jumps every motor to its commanded speed, as if it had been running for a long time.
    pub(crate) fn settle(&mut self) {
        self.speed_rad_s = self.target_rad_s;
    }

    /// Advances the lag by `dt_s`, exactly (the discrete form of dω/dt = (ω_cmd − ω)/τ).
    pub(crate) fn advance(&mut self, dt_s: f64) {
        let blend = 1.0 - (-dt_s / self.params.time_constant_s).exp();
        for (speed, target) in self.speed_rad_s.iter_mut().zip(&self.target_rad_s) {
            *speed += (target - *speed) * blend;
        }
    }

    /// Total thrust force and torque about the centre of mass, body FRD (N, N·m).
    pub(crate) fn force_torque_frd(&self) -> (Vector3<f64>, Vector3<f64>) {
        let mut force = Vector3::zeros();
        let mut torque = Vector3::zeros();
        if !self.props_on {
            return (force, torque);
        }
        for ((motor, &speed), &scale) in self.geometry.iter().zip(&self.speed_rad_s).zip(&self.scale) {
            let w2 = speed * speed * scale;
            let thrust = Vector3::new(0.0, 0.0, -self.params.thrust_coefficient_n_per_rad2_s2 * w2);
            force += thrust;
            torque += motor.position_frd_m.cross(&thrust);
            torque.z += motor.spin.yaw_sign() * self.params.torque_coefficient_n_m_per_rad2_s2 * w2;
        }
        (force, torque)
    }

    /// Mechanical power the propellers absorb (W): drag torque times speed.
    pub(crate) fn shaft_power_w(&self) -> f64 {
        if !self.props_on {
            return 0.0;
        }
        let k_m = self.params.torque_coefficient_n_m_per_rad2_s2;
        let n = self.geometry.len();
        self.speed_rad_s[..n].iter().zip(&self.scale[..n]).map(|(w, scale)| k_m * scale * w.powi(3)).sum()
    }

    /// Thrust each motor produces now over one healthy motor's full thrust, in mixer order
    /// (entries past the frame's motors 0): what an ESC's telemetry tells of it.
    pub(crate) fn thrust_fractions(&self) -> [f64; MAX_MOTORS] {
        let mut out = [0.0; MAX_MOTORS];
        let n = if self.props_on { self.geometry.len() } else { 0 };
        for ((out, &speed), &scale) in out[..n].iter_mut().zip(&self.speed_rad_s).zip(&self.scale) {
            *out = scale * (speed / self.params.max_speed_rad_s).powi(2);
        }
        out
    }

    /// Current speeds of all motor slots, in mixer order (rad/s; 0 past the frame's motors): what
    /// an ESC's telemetry reports.
    pub(crate) fn speeds_all_rad_s(&self) -> [f64; MAX_MOTORS] {
        let mut out = [0.0; MAX_MOTORS];
        let n = self.geometry.len();
        out[..n].copy_from_slice(&self.speed_rad_s[..n]);
        out
    }

    /// Current speeds of the frame's motors, in mixer order (rad/s).
    pub(crate) fn speeds_rad_s(&self) -> &[f64] {
        &self.speed_rad_s[..self.geometry.len()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_map_linearly_to_thrust_and_bad_commands_clamp() {
        let p = MotorParams::default();
        let thrust = |u: f64| p.thrust_coefficient_n_per_rad2_s2 * p.commanded_speed_rad_s(u).powi(2);
        assert!((thrust(0.25) - 0.25 * p.max_thrust_n()).abs() < 1e-12);
        assert!((thrust(0.8) - 0.8 * p.max_thrust_n()).abs() < 1e-12);
        assert_eq!(p.commanded_speed_rad_s(f64::NAN), 0.0);
        assert_eq!(p.commanded_speed_rad_s(-1.0), 0.0);
        assert_eq!(p.commanded_speed_rad_s(7.0), p.max_speed_rad_s);
    }

    #[test]
    fn each_esc_reads_the_pulse_against_its_own_range_and_a_calibrated_output_undoes_it() {
        let nominal = MotorParams::default();
        let mut motors = Motors::new(&nominal, FrameLayout::QuadX, 0.225);
        let mut outputs = ActuatorOutputs { armed: true, ..ActuatorOutputs::default() };
        outputs.motors[..4].copy_from_slice(&[0.0, 0.3, 0.61, 1.0]);
        motors.command(&outputs);
        for (target, &u) in motors.target_rad_s.iter().zip(&outputs.motors) {
            assert_eq!(
                *target,
                nominal.commanded_speed_rad_s(u),
                "nominal ranges: the command itself, exactly"
            );
        }

        let p = MotorParams { esc_range_us: vec![[1100.0, 1900.0]; 4], ..MotorParams::default() };
        assert_eq!(p.validate(), Ok(()));
        let mut motors = Motors::new(&p, FrameLayout::QuadX, 0.225);
        outputs.motors[..4].copy_from_slice(&[0.1, 0.5, 0.3, 0.95]);
        motors.command(&outputs);
        // Uncalibrated: 0.1 → 1100 µs, the ESC's start; 0.5 → 1500 µs, half; 0.95 → past full.
        let throttle = |w: f64| (w / p.max_speed_rad_s).powi(2);
        assert_eq!(motors.target_rad_s[0], 0.0);
        assert!((throttle(motors.target_rad_s[1]) - 0.5).abs() < 1e-12);
        assert!((throttle(motors.target_rad_s[2]) - 0.25).abs() < 1e-12, "0.3 commanded, 0.25 given");
        assert_eq!(motors.target_rad_s[3], p.max_speed_rad_s);
        motors.set_output_ranges(&EscRanges::uniform(1100.0, 1900.0));
        motors.command(&outputs);
        for (target, &u) in motors.target_rad_s.iter().zip(&outputs.motors).take(4) {
            assert!((throttle(*target) - u).abs() < 1e-12, "calibrated: throttle = command {u}");
        }
        motors.command_pulses(&[1300.0; MAX_MOTORS]);
        assert!((throttle(motors.target_rad_s[2]) - 0.25).abs() < 1e-12);

        // Propellers off: the motors turn and push nothing.
        motors.settle();
        motors.set_props_on(false);
        let (force, torque) = motors.force_torque_frd();
        assert_eq!((force.norm(), torque.norm(), motors.shaft_power_w()), (0.0, 0.0, 0.0));
        assert_eq!(motors.thrust_fractions(), [0.0; MAX_MOTORS]);
        assert!(motors.speeds_all_rad_s()[..4].iter().all(|&w| w > 400.0));

        for bad in [vec![[1100.0, 1150.0]; 4], vec![[700.0, 1900.0]; 4], vec![[1100.0, f64::NAN]; 4]] {
            let p = MotorParams { esc_range_us: bad.clone(), ..MotorParams::default() };
            assert!(p.validate().is_err(), "{bad:?}");
        }
        let three = MotorParams { esc_range_us: vec![[1100.0, 1900.0]; 3], ..MotorParams::default() };
        assert!(three.validate_for(4).is_err() && three.validate_for(3).is_ok());
    }

    #[test]
    fn a_weak_motor_gives_its_share_of_thrust_and_torque_and_a_lost_one_none() {
        let p = MotorParams::default();
        let mut motors = Motors::new(&p, FrameLayout::QuadX, 0.225);
        let mut hover = ActuatorOutputs { armed: true, ..ActuatorOutputs::default() };
        hover.motors[..4].fill(0.4);
        motors.command(&hover);
        motors.settle();
        let (healthy_force, _) = motors.force_torque_frd();
        let per_motor_n = 0.4 * p.max_thrust_n();
        assert!((healthy_force.z + 4.0 * per_motor_n).abs() < 1e-9, "{healthy_force}");
        let healthy_power = motors.shaft_power_w();

        let mut faults = MotorFaults::default();
        faults.thrust_scale[0] = 0.5;
        motors.set_faults(&faults);
        let (force, torque) = motors.force_torque_frd();
        // Motor 1 gives half its thrust: 3.5 motors' worth, and a roll/pitch/yaw moment of the
        // missing half at motor 1's place.
        assert!((force.z + 3.5 * per_motor_n).abs() < 1e-9, "{force}");
        let m1 = &motors.geometry[0];
        let missing = Vector3::new(0.0, 0.0, -0.5 * per_motor_n);
        let expected = -m1.position_frd_m.cross(&missing)
            - Vector3::new(
                0.0,
                0.0,
                m1.spin.yaw_sign() * 0.5 * per_motor_n * p.torque_coefficient_n_m_per_rad2_s2
                    / p.thrust_coefficient_n_per_rad2_s2,
            );
        assert!((torque - expected).norm() < 1e-9, "{torque} vs {expected}");
        assert!((motors.shaft_power_w() - 0.875 * healthy_power).abs() < 1e-9);

        faults.thrust_scale[0] = 0.0;
        motors.set_faults(&faults);
        assert!((motors.force_torque_frd().0.z + 3.0 * per_motor_n).abs() < 1e-9);
        motors.set_faults(&MotorFaults::default());
        assert_eq!(motors.force_torque_frd().0, healthy_force);
    }
}
