//! `ControlParams`: everything the control loop is tuned by, one serde table with defaults
//! tuned for `config/vehicles/quad_x.toml` (see each part's `Default`).

use serde::{Deserialize, Serialize};

use crate::airframe::AirframeParams;
use crate::attitude::AttitudeGains;
use crate::backup_attitude::BackupAttitudeParams;
use crate::error::{InvalidParam, positive, within};
use crate::position::PositionGains;
use crate::rate::RateGains;

/// The control loop's parameters (`[actors.controller.params]`, or `config/control/*.toml`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ControlParams {
    pub airframe: AirframeParams,
    pub attitude: AttitudeGains,
    pub rate: RateGains,
    pub position: PositionGains,
    pub timing: LoopParams,
    /// The attitude flown when the estimator's NavState is gone (`backup_attitude`).
    pub backup: BackupAttitudeParams,
}

/// Timing and the loop's own failsafes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LoopParams {
    /// Rate of the real-time loop on hardware (Hz); in lockstep the loop runs once per NavState.
    pub rate_hz: f64,
    /// A NavState older than this is stale (s): the loop levels the thrust and descends.
    pub nav_timeout_s: f64,
    /// A setpoint older than this is lost (s): the loop holds position (if it can) and descends.
    pub setpoint_timeout_s: f64,
    /// Descent rate when the setpoint is lost (m/s).
    pub failsafe_descent_m_s: f64,
    /// Collective thrust, as a share of hover thrust, while flying without a NavState.
    pub blind_thrust_of_hover: f64,
}

impl Default for LoopParams {
    fn default() -> LoopParams {
        LoopParams {
            rate_hz: 400.0,
            nav_timeout_s: 0.05,
            setpoint_timeout_s: 0.5,
            failsafe_descent_m_s: 1.0,
            blind_thrust_of_hover: 0.92,
        }
    }
}

impl ControlParams {
    /// Checks every field; the error names the first offending one.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        self.airframe.validate()?;
        self.attitude.validate()?;
        self.rate.validate()?;
        self.position.validate()?;
        self.backup.validate()?;
        let l = &self.timing;
        within("timing.rate_hz", l.rate_hz, 50.0, 2000.0)?;
        positive("timing.nav_timeout_s", l.nav_timeout_s)?;
        positive("timing.setpoint_timeout_s", l.setpoint_timeout_s)?;
        positive("timing.failsafe_descent_m_s", l.failsafe_descent_m_s)?;
        within("timing.blind_thrust_of_hover", l.blind_thrust_of_hover, 0.5, 1.0)
    }

    /// Collective thrust share that hovers (the override, else the airframe's).
    pub fn hover_thrust(&self) -> f64 {
        self.position.hover_thrust.unwrap_or_else(|| self.airframe.hover_thrust())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_unknown_fields_are_refused() {
        ControlParams::default().validate().expect("defaults valid");
        let err = serde_json::from_str::<ControlParams>(r#"{"rate": {"q": [1, 2, 3]}}"#);
        assert!(err.is_err());
        let bad = ControlParams {
            rate: RateGains { p: [f64::NAN, 1.0, 1.0], ..RateGains::default() },
            ..ControlParams::default()
        };
        assert_eq!(bad.validate().unwrap_err().name, "rate.p[0]");
    }
}
