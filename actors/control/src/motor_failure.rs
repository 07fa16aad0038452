//! Motor-failure detection from ESC telemetry: PX4's `FailureDetector` actuator check.
//!
//! A motor is declared failed when it is commanded above a throttle threshold
//! (`FD_ACT_MOT_THR`) while the thrust fraction its ESC reports stays below a fraction of the
//! command (PX4 compares current against throttle with `FD_ACT_MOT_C2T`; Kestrel's ESC
//! telemetry reports the thrust fraction actually produced, so the ratio is dimensionless)
//! for longer than `FD_ACT_MOT_TOUT`. The check is enabled by `FD_ACT_EN`. A failure latches:
//! a motor that stopped once is not trusted again in the same flight.
//!
//! Without ESC telemetry (Navio2 PWM outputs have none) the detector has no input and never
//! fires. Pure and allocation-free: it runs on the 400 Hz loop.

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Most motors a detector tracks (octocopter).
pub const MAX_MOTORS: usize = 8;

/// Detector parameters, named after PX4's.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MotorFailureParams {
    /// `FD_ACT_EN`: run the check at all.
    pub enabled: bool,
    /// `FD_ACT_MOT_THR`: command (0..1) above which a motor must produce thrust. PX4 default 0.2.
    pub throttle_threshold: f32,
    /// Telemetry below `command × ratio` counts as "not producing" (0..1). Kestrel default 0.5.
    pub telemetry_ratio: f32,
    /// `FD_ACT_MOT_TOUT`: how long the shortfall must last, s. PX4 default 0.1 s.
    pub timeout_s: f32,
}

impl Default for MotorFailureParams {
    fn default() -> Self {
        Self { enabled: true, throttle_threshold: 0.2, telemetry_ratio: 0.5, timeout_s: 0.1 }
    }
}

/// Input the detector refuses rather than judge on.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum MotorFailureError {
    #[error("motor {motor}: command {value} is not a finite value in 0..=1")]
    BadCommand { motor: usize, value: f32 },
    #[error("motor {motor}: telemetry {value} is not a finite value >= 0")]
    BadTelemetry { motor: usize, value: f32 },
    #[error("dt {0} s is not finite and positive")]
    BadDt(f32),
    #[error("{commands} commands but {telemetry} telemetry values (at most {MAX_MOTORS})")]
    Count { commands: usize, telemetry: usize },
    #[error("parameters invalid: {0}")]
    BadParams(&'static str),
}

/// Per-motor shortfall timers and the latched failure.
#[derive(Debug, Clone)]
pub struct MotorFailureDetector {
    params: MotorFailureParams,
    shortfall_s: [f32; MAX_MOTORS],
    failed: Option<usize>,
}

impl MotorFailureDetector {
    pub fn new(params: MotorFailureParams) -> Result<Self, MotorFailureError> {
        let p = params;
        if !(p.throttle_threshold.is_finite() && (0.0..1.0).contains(&p.throttle_threshold)) {
            return Err(MotorFailureError::BadParams("FD_ACT_MOT_THR must be in 0..1"));
        }
        if !(p.telemetry_ratio.is_finite() && p.telemetry_ratio > 0.0 && p.telemetry_ratio < 1.0) {
            return Err(MotorFailureError::BadParams("telemetry ratio must be in (0, 1)"));
        }
        if !(p.timeout_s.is_finite() && p.timeout_s > 0.0) {
            return Err(MotorFailureError::BadParams("FD_ACT_MOT_TOUT must be > 0"));
        }
        Ok(Self { params, shortfall_s: [0.0; MAX_MOTORS], failed: None })
    }

    /// Takes new (validated) parameters; the timers and a latched failure are kept.
    pub fn set_params(&mut self, params: MotorFailureParams) -> Result<(), MotorFailureError> {
        Self::new(params)?;
        self.params = params;
        Ok(())
    }

    /// Forgets the timers and the latched failure (a new flight).
    pub fn reset(&mut self) {
        self.shortfall_s = [0.0; MAX_MOTORS];
        self.failed = None;
    }

    /// The first motor declared failed, 0-based, if any.
    pub fn failed(&self) -> Option<usize> {
        self.failed
    }

    /// One step: `commands` are the mixer outputs (0..1), `telemetry` the thrust fractions the
    /// ESCs report for the same motors, `dt` seconds since the last step. Invalid input is
    /// refused and leaves the state untouched.
    pub fn update(
        &mut self,
        commands: &[f32],
        telemetry: &[f32],
        dt: f32,
    ) -> Result<Option<usize>, MotorFailureError> {
        if commands.len() != telemetry.len() || commands.len() > MAX_MOTORS {
            return Err(MotorFailureError::Count { commands: commands.len(), telemetry: telemetry.len() });
        }
        if !(dt.is_finite() && dt > 0.0) {
            return Err(MotorFailureError::BadDt(dt));
        }
        for (motor, (&c, &t)) in commands.iter().zip(telemetry).enumerate() {
            if !(c.is_finite() && (0.0..=1.0).contains(&c)) {
                return Err(MotorFailureError::BadCommand { motor, value: c });
            }
            if !(t.is_finite() && t >= 0.0) {
                return Err(MotorFailureError::BadTelemetry { motor, value: t });
            }
        }
        if !self.params.enabled || self.failed.is_some() {
            return Ok(self.failed);
        }
        for (motor, (&c, &t)) in commands.iter().zip(telemetry).enumerate() {
            let short = c > self.params.throttle_threshold && t < c * self.params.telemetry_ratio;
            self.shortfall_s[motor] = if short { self.shortfall_s[motor] + dt } else { 0.0 };
            if self.shortfall_s[motor] > self.params.timeout_s && self.failed.is_none() {
                self.failed = Some(motor);
            }
        }
        Ok(self.failed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const DT: f32 = 0.0025;

    fn det() -> MotorFailureDetector {
        MotorFailureDetector::new(MotorFailureParams::default()).unwrap()
    }

    #[test]
    fn stopped_motor_declared_after_timeout_not_before() {
        let mut d = det();
        let cmd = [0.5; 6];
        let mut tel = [0.5; 6];
        tel[1] = 0.0;
        // 0.1 s at 400 Hz is 40 steps: still inside the timeout.
        for _ in 0..40 {
            assert_eq!(d.update(&cmd, &tel, DT).unwrap(), None);
        }
        for _ in 0..2 {
            d.update(&cmd, &tel, DT).unwrap();
        }
        assert_eq!(d.failed(), Some(1));
    }

    #[test]
    fn low_command_never_judged() {
        let mut d = det();
        for _ in 0..1000 {
            assert_eq!(d.update(&[0.1; 4], &[0.0; 4], DT).unwrap(), None);
        }
    }

    #[test]
    fn disabled_never_fires() {
        let p = MotorFailureParams { enabled: false, ..Default::default() };
        let mut d = MotorFailureDetector::new(p).unwrap();
        for _ in 0..1000 {
            assert_eq!(d.update(&[0.8; 4], &[0.0; 4], DT).unwrap(), None);
        }
    }

    #[test]
    fn nan_and_mismatch_refused() {
        let mut d = det();
        assert!(d.update(&[f32::NAN; 4], &[0.5; 4], DT).is_err());
        assert!(d.update(&[0.5; 4], &[f32::INFINITY; 4], DT).is_err());
        assert!(d.update(&[0.5; 4], &[0.5; 3], DT).is_err());
        assert!(d.update(&[0.5; 4], &[0.5; 4], f32::NAN).is_err());
        let bad = MotorFailureParams { timeout_s: f32::NAN, ..Default::default() };
        assert!(MotorFailureDetector::new(bad).is_err());
    }

    proptest! {
        /// Telemetry at or above the command ratio never triggers, whatever the commands.
        #[test]
        fn healthy_never_fires(
            steps in proptest::collection::vec(
                (proptest::collection::vec(0.0f32..=1.0, 6), 0.5f32..=1.2), 1..400)
        ) {
            let mut d = det();
            for (cmd, gain) in steps {
                let tel: Vec<f32> = cmd.iter().map(|c| c * gain).collect();
                prop_assert_eq!(d.update(&cmd, &tel, DT).unwrap(), None);
            }
        }
    }
}
