//! HEARTBEAT: ours at 1 Hz (the timer lives in the shell), and the ground station's, whose loss
//! we report. The commander owns the data-link failsafe: every GCS heartbeat goes to it as
//! `Command::Heartbeat` with the sender's system id, and only `MAV_GCS_SYSID`'s refresh its
//! timer (and this watch).

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::messages::{FailsafeAction, FailsafeCause, FlightMode, VehicleStatus};
use mavlink::dialects::ardupilotmega::{HEARTBEAT_DATA, MavAutopilot, MavModeFlag, MavState, MavType};

use crate::modes::custom_mode;

/// Our HEARTBEAT for the commander's latest status (`None`: no status yet, still booting).
pub fn vehicle_heartbeat(status: Option<&VehicleStatus>) -> HEARTBEAT_DATA {
    let Some(status) = status else {
        return HEARTBEAT_DATA {
            custom_mode: 0,
            mavtype: MavType::MAV_TYPE_QUADROTOR,
            autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
            system_status: MavState::MAV_STATE_BOOT,
            mavlink_version: 3,
        };
    };
    let mut base_mode =
        MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | MavModeFlag::MAV_MODE_FLAG_STABILIZE_ENABLED;
    if status.armed {
        base_mode |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
    }
    base_mode |= match status.mode {
        FlightMode::Stabilize | FlightMode::Acro | FlightMode::AltHold | FlightMode::PosHold => {
            MavModeFlag::MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
        }
        FlightMode::Guided | FlightMode::Takeoff | FlightMode::Brake => {
            MavModeFlag::MAV_MODE_FLAG_GUIDED_ENABLED
        }
        FlightMode::Auto
        | FlightMode::ReturnToLaunch
        | FlightMode::Land
        | FlightMode::Circle
        | FlightMode::Follow => {
            MavModeFlag::MAV_MODE_FLAG_GUIDED_ENABLED | MavModeFlag::MAV_MODE_FLAG_AUTO_ENABLED
        }
    };
    HEARTBEAT_DATA {
        custom_mode: custom_mode(status.mode),
        mavtype: MavType::MAV_TYPE_QUADROTOR,
        autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode,
        system_status: system_status(status),
        mavlink_version: 3,
    }
}

/// `MAV_STATE` from the failsafe in force: EMERGENCY when the battery is critical or the
/// vehicle is being stopped, CRITICAL under any other acting failsafe, else STANDBY/ACTIVE.
pub fn system_status(status: &VehicleStatus) -> MavState {
    match status.failsafe {
        Some(f) if f.cause == FailsafeCause::BatteryCritical || f.action == FailsafeAction::Disarm => {
            MavState::MAV_STATE_EMERGENCY
        }
        Some(f) if f.action != FailsafeAction::Warn => MavState::MAV_STATE_CRITICAL,
        _ if status.armed => MavState::MAV_STATE_ACTIVE,
        _ => MavState::MAV_STATE_STANDBY,
    }
}

/// Whether the ground station is heard.
#[derive(Debug)]
pub struct GcsWatch {
    timeout: Duration,
    last_heard: Option<Time>,
    lost: bool,
}

/// A change in the ground station's presence.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GcsEvent {
    Regained,
    Lost,
}

impl GcsWatch {
    /// Watches for heartbeats at least every `timeout`.
    pub fn new(timeout: Duration) -> GcsWatch {
        GcsWatch { timeout, last_heard: None, lost: false }
    }

    /// A GCS heartbeat arrived.
    pub fn heard(&mut self, now: Time) -> Option<GcsEvent> {
        self.last_heard = Some(now);
        std::mem::take(&mut self.lost).then_some(GcsEvent::Regained)
    }

    /// Checks the timeout; reports the moment the link is lost.
    pub fn check(&mut self, now: Time) -> Option<GcsEvent> {
        let heard = self.last_heard?;
        if !self.lost && now.saturating_since(heard) > self.timeout {
            self.lost = true;
            return Some(GcsEvent::Lost);
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::messages::{Failsafe, LandedState};
    use kestrel_proto::testing::vehicle_status;

    use super::*;

    fn status(armed: bool, mode: FlightMode) -> VehicleStatus {
        vehicle_status(Time::ZERO, armed, mode, LandedState::OnGround)
    }

    #[test]
    fn armed_auto_reports_flags_mode_and_state() {
        let hb = vehicle_heartbeat(Some(&status(true, FlightMode::Auto)));
        assert_eq!(hb.custom_mode, 3);
        assert!(hb.base_mode.contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED));
        assert!(hb.base_mode.contains(MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED));
        assert_eq!(hb.system_status, MavState::MAV_STATE_ACTIVE);
        assert_eq!(hb.mavtype, MavType::MAV_TYPE_QUADROTOR);
        let idle = vehicle_heartbeat(Some(&status(false, FlightMode::Stabilize)));
        assert!(!idle.base_mode.contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED));
        assert_eq!(idle.system_status, MavState::MAV_STATE_STANDBY);
        assert_eq!(vehicle_heartbeat(None).system_status, MavState::MAV_STATE_BOOT);
    }

    #[test]
    fn failsafes_raise_the_system_status() {
        let mut s = status(true, FlightMode::ReturnToLaunch);
        s.failsafe = Some(Failsafe {
            cause: FailsafeCause::DataLinkLost,
            action: FailsafeAction::ReturnToLaunch,
            since: Time::ZERO,
        });
        assert_eq!(system_status(&s), MavState::MAV_STATE_CRITICAL);
        s.failsafe = Some(Failsafe {
            cause: FailsafeCause::BatteryCritical,
            action: FailsafeAction::Land,
            since: Time::ZERO,
        });
        assert_eq!(system_status(&s), MavState::MAV_STATE_EMERGENCY);
    }

    #[test]
    fn gcs_loss_is_reported_once_and_regained() {
        let mut w = GcsWatch::new(Duration::from_secs(5));
        assert_eq!(w.check(Time::from_secs_f64(100.0)), None, "never heard: nothing to lose");
        assert_eq!(w.heard(Time::from_secs_f64(1.0)), None);
        assert_eq!(w.check(Time::from_secs_f64(5.9)), None);
        assert_eq!(w.check(Time::from_secs_f64(6.1)), Some(GcsEvent::Lost));
        assert_eq!(w.check(Time::from_secs_f64(7.0)), None);
        assert_eq!(w.heard(Time::from_secs_f64(8.0)), Some(GcsEvent::Regained));
    }
}
