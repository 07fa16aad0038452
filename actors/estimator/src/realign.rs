//! When to align the filter again after a sensor calibration changed: at once on a disarmed
//! vehicle, after the disarm on an armed one, never in the air.
//!
//! The calibration parameters (`COMPASS_*`, `INS_*`, `AHRS_TRIM_*`: [`CALIBRATION_PARAMS`]) are
//! owned by the sensor path (driver or simulator), which corrects its samples from the moment
//! a new value arrives. The filter converged on the old correction, so its tilt, yaw, Earth
//! field and biases are off by the change. A vehicle at rest aligns again, as PX4's EKF2 resets
//! its biases and heading when a calibration changes; an armed vehicle keeps flying on what it
//! has (the new samples look like a bias step or a magnetic anomaly, which the filter's gates
//! and bias states handle) and aligns again once disarmed. Until a vehicle status says
//! disarmed, the state is unknown and a change waits: a restarted estimator in flight must not
//! throw its estimate away.

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::calibration::{CALIBRATION_PARAMS, CalibrationParams};

/// Samples measured this soon after a change may carry either correction: the sensor path
/// applies the new value when its own mailbox delivers the change, a step or two later. The
/// new alignment starts after it.
pub const SETTLE: Duration = Duration::from_millis(100);

/// Tracks the calibration in use and the vehicle's arming to decide when to align again.
#[derive(Clone, Debug, Default)]
pub struct RealignPolicy {
    /// The calibration as the parameter changes seen so far set it.
    calibration: CalibrationParams,
    /// Armed (`Some(true)`), disarmed (`Some(false)`) or not yet told.
    armed: Option<bool>,
    /// A change seen while armed or before any status, waiting for a disarmed vehicle.
    pending: bool,
}

impl RealignPolicy {
    /// A parameter change `name = value` at `time`; returns the time to align again from
    /// ([`SETTLE`] after it) when it changed a calibration value of a vehicle known to be
    /// disarmed.
    pub fn on_param(&mut self, name: &str, value: f64, time: Time) -> Option<Time> {
        if !CALIBRATION_PARAMS.iter().any(|d| d.name == name) {
            return None;
        }
        let updated = self.calibration.with(name, value);
        if updated == self.calibration {
            return None;
        }
        self.calibration = updated;
        if self.armed == Some(false) {
            return Some(time + SETTLE);
        }
        self.pending = true;
        None
    }

    /// A vehicle status at `time`; returns the time to align again from ([`SETTLE`] after it)
    /// when a change was waiting for this disarmed vehicle.
    pub fn on_status(&mut self, armed: bool, time: Time) -> Option<Time> {
        self.armed = Some(armed);
        if armed || !self.pending {
            return None;
        }
        self.pending = false;
        Some(time + SETTLE)
    }

    /// Whether a change waits for the vehicle to disarm.
    pub fn pending(&self) -> bool {
        self.pending
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(s: f64) -> Time {
        Time::from_secs_f64(s)
    }

    #[test]
    fn a_disarmed_vehicle_aligns_again_at_each_calibration_change_only() {
        let mut p = RealignPolicy::default();
        assert_eq!(p.on_status(false, t(1.0)), None, "nothing changed yet");
        assert_eq!(p.on_param("COMPASS_OFS_X", -150.0, t(2.0)), Some(t(2.0) + SETTLE));
        assert_eq!(p.on_param("COMPASS_OFS_X", -150.0, t(2.1)), None, "the same value again");
        assert_eq!(p.on_param("RTL_ALT_M", 25.0, t(2.2)), None, "not a calibration parameter");
        assert_eq!(p.on_param("AHRS_TRIM_X", 0.03, t(2.3)), Some(t(2.3) + SETTLE));
        assert!(!p.pending());
    }

    #[test]
    fn an_armed_vehicle_waits_for_the_disarm() {
        let mut p = RealignPolicy::default();
        p.on_status(true, t(1.0));
        assert_eq!(p.on_param("INS_ACCOFFS_Z", 0.3, t(5.0)), None, "never in flight");
        assert!(p.pending());
        assert_eq!(p.on_status(true, t(6.0)), None, "still armed");
        assert_eq!(p.on_status(false, t(30.0)), Some(t(30.0) + SETTLE), "aligns once disarmed");
        assert_eq!(p.on_status(false, t(31.0)), None, "and once only");
    }

    #[test]
    fn before_any_status_a_change_waits() {
        let mut p = RealignPolicy::default();
        assert_eq!(p.on_param("COMPASS_DIA_X", 0.9, t(0.1)), None);
        assert!(p.pending(), "a restarted estimator may be in the air");
        assert_eq!(p.on_status(false, t(0.5)), Some(t(0.5) + SETTLE));
    }
}
