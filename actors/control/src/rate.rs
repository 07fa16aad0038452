//! The inner, body-rate loop: rate setpoint → torque.
//!
//! PID on the rate error per axis, giving an angular-acceleration demand that is turned into
//! torque through the inertia, with the gyroscopic term `ω × Jω` added (Lee et al. 2010), so
//! the gains are independent of the airframe's size. The derivative acts on the measured rate
//! (no kick on setpoint steps) through a first-order low-pass. The integrator is clamped and
//! frozen on any axis the mixer reported saturated (PX4's practice), and reset on the ground.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, non_negative, positive};
use crate::mixer::Saturation;

/// `[rate]` gains and limits (per axis: forward, right, down). Defaults tuned for quad_x.toml.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RateGains {
    /// Angular acceleration per rad/s of rate error (1/s).
    pub p: [f64; 3],
    /// Angular acceleration per rad of integrated rate error (1/s²).
    pub i: [f64; 3],
    /// Angular acceleration per rad/s² of measured angular acceleration (dimensionless).
    pub d: [f64; 3],
    /// Bound of the integral term (rad/s²).
    pub integral_limit_rad_s2: [f64; 3],
    /// Cut-off of the derivative's low-pass filter (Hz).
    pub derivative_cutoff_hz: f64,
}

impl Default for RateGains {
    fn default() -> RateGains {
        RateGains {
            p: [18.0, 18.0, 8.0],
            i: [12.0, 12.0, 4.0],
            d: [0.08, 0.08, 0.0],
            integral_limit_rad_s2: [12.0, 12.0, 4.0],
            derivative_cutoff_hz: 30.0,
        }
    }
}

impl RateGains {
    pub(crate) fn validate(&self) -> Result<(), InvalidParam> {
        for a in 0..3 {
            positive(&format!("rate.p[{a}]"), self.p[a])?;
            non_negative(&format!("rate.i[{a}]"), self.i[a])?;
            non_negative(&format!("rate.d[{a}]"), self.d[a])?;
            non_negative(&format!("rate.integral_limit_rad_s2[{a}]"), self.integral_limit_rad_s2[a])?;
        }
        positive("rate.derivative_cutoff_hz", self.derivative_cutoff_hz)
    }
}

/// Rate PID state.
#[derive(Clone, Debug)]
pub struct RateController {
    gains: RateGains,
    inertia_frd_kg_m2: Vector3<f64>,
    /// Integral term (rad/s²).
    integral: Vector3<f64>,
    /// Previous measured rate, for the derivative (rad/s); `None` after a reset.
    last_rate: Option<Vector3<f64>>,
    /// Filtered angular acceleration (rad/s²).
    accel_filtered: Vector3<f64>,
}

impl RateController {
    pub fn new(gains: RateGains, inertia_frd_kg_m2: [f64; 3]) -> RateController {
        RateController {
            gains,
            inertia_frd_kg_m2: inertia_frd_kg_m2.into(),
            integral: Vector3::zeros(),
            last_rate: None,
            accel_filtered: Vector3::zeros(),
        }
    }

    /// Takes new (validated) gains from the next step on; the integral is kept (and bounded by
    /// the new limit on that step), so a retune in flight causes no thrust step.
    pub fn set_gains(&mut self, gains: RateGains) {
        self.gains = gains;
    }

    /// Forgets the integral and derivative history (on the ground, on mode changes to idle).
    pub fn reset(&mut self) {
        self.integral = Vector3::zeros();
        self.last_rate = None;
        self.accel_filtered = Vector3::zeros();
    }

    /// The integral term (rad/s²), for tests and logs.
    pub fn integral(&self) -> Vector3<f64> {
        self.integral
    }

    /// Torque (body FRD, N·m) for a rate setpoint, given the measured rate, the step `dt_s`
    /// and what the mixer saturated on the previous step.
    pub fn torque(
        &mut self,
        rate_sp_rad_s: &Vector3<f64>,
        rate_rad_s: &Vector3<f64>,
        dt_s: f64,
        saturation: Saturation,
    ) -> Vector3<f64> {
        let g = &self.gains;
        let error = rate_sp_rad_s - rate_rad_s;
        let accel = match self.last_rate {
            Some(last) if dt_s > 0.0 => (rate_rad_s - last) / dt_s,
            _ => Vector3::zeros(),
        };
        self.last_rate = Some(*rate_rad_s);
        let alpha = 1.0 - (-2.0 * std::f64::consts::PI * g.derivative_cutoff_hz * dt_s).exp();
        self.accel_filtered += (accel - self.accel_filtered) * alpha;
        let frozen = [saturation.roll_pitch, saturation.roll_pitch, saturation.yaw];
        let mut demand = Vector3::zeros();
        for a in 0..3 {
            if !frozen[a] {
                let limit = g.integral_limit_rad_s2[a];
                self.integral[a] = (self.integral[a] + g.i[a] * error[a] * dt_s).clamp(-limit, limit);
            }
            demand[a] = g.p[a] * error[a] + self.integral[a] - g.d[a] * self.accel_filtered[a];
        }
        let j = self.inertia_frd_kg_m2;
        j.component_mul(&demand) + rate_rad_s.cross(&j.component_mul(rate_rad_s))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrator_freezes_while_saturated_and_stays_bounded() {
        let mut rate = RateController::new(RateGains::default(), [0.029, 0.029, 0.055]);
        let sp = Vector3::new(1.0, 0.0, 1.0);
        let saturated = Saturation { roll_pitch: true, ..Saturation::default() };
        for _ in 0..400 {
            rate.torque(&sp, &Vector3::zeros(), 0.0025, saturated);
        }
        assert_eq!(rate.integral().x, 0.0);
        assert!(rate.integral().z > 0.0);
        for _ in 0..40_000 {
            rate.torque(&sp, &Vector3::zeros(), 0.0025, Saturation::default());
        }
        assert_eq!(rate.integral().x, 12.0);
        assert_eq!(rate.integral().z, 4.0);
    }
}
