//! Stopping the process with the vehicle armed (`Command::Shutdown`, sent by the runtime on
//! SIGTERM, SIGINT or SIGHUP).
//!
//! Ending the process would stop the motors wherever the vehicle is, so the commander first
//! brings it down: in the air it lands where it is, as LAND does (level and descend without a
//! position), and says so; on the ground it disarms at once. The runtime exits once the status
//! shows the vehicle disarmed. A pilot may still take over with a mode change, as from any
//! failsafe landing; the process then waits for the next disarm.
//! Held by the tests `shutdown_in_the_air_lands_and_announces_it` and
//! `shutdown_on_the_ground_disarms_at_once`, and in flight by tests/hil_shutdown.rs.

use kestrel_proto::Time;
use kestrel_proto::messages::{FlightMode, LandedState};

use super::Commander;

/// The STATUSTEXT a ground station shows when a shutdown lands the vehicle.
pub const SHUTDOWN_LANDING: &str = "shutdown requested: landing";
/// The STATUSTEXT when a shutdown disarms a vehicle that is on the ground.
pub const SHUTDOWN_DISARMED: &str = "shutdown requested: disarmed on the ground";

impl Commander {
    pub(super) fn on_shutdown(&mut self, now: Time) {
        if !self.armed {
            return;
        }
        if self.landing.state() == LandedState::OnGround {
            self.disarm("shutdown");
            self.announce(SHUTDOWN_DISARMED.into());
            return;
        }
        tracing::warn!(t_s = now.as_secs_f64(), "shutdown requested in flight: landing first");
        if self.mode != FlightMode::Land {
            self.enter(FlightMode::Land);
        }
        self.boot_mode = false;
        self.announce(SHUTDOWN_LANDING.into());
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::Time;
    use kestrel_proto::messages::{Command, FlightMode, LandedState, SetpointTarget};

    use super::{SHUTDOWN_DISARMED, SHUTDOWN_LANDING};
    use crate::commander::tests::{at, hovering, nav, ready};

    #[test]
    fn shutdown_in_the_air_lands_and_announces_it() {
        let mut c = hovering();
        at(&mut c, 3000, Command::Shutdown).expect("accepted");
        assert_eq!(c.mode(), FlightMode::Land);
        let status = c.status(Time(3000));
        assert!(status.armed, "the motors keep running in the air");
        assert_eq!(status.last_refusal.as_deref(), Some(SHUTDOWN_LANDING));
        let sp = c.update(Time(3000));
        assert_ne!(sp.target, SetpointTarget::MotorsOff);
        // Sent again (a second signal), it neither disarms nor restarts the land detector.
        at(&mut c, 4000, Command::Shutdown).expect("accepted");
        assert!(c.armed() && c.mode() == FlightMode::Land);
        let mut t = 4000;
        while c.armed() && t < 5_000_000 {
            t += 2500;
            c.on_nav(&nav(Time(t), 0.0, true));
            c.update(Time(t));
        }
        assert!(!c.armed(), "the landing disarms on touchdown");
        assert_eq!(c.landed(), LandedState::OnGround);
    }

    #[test]
    fn shutdown_on_the_ground_disarms_at_once() {
        let mut c = ready(true);
        at(&mut c, 1000, Command::SetMode(FlightMode::PosHold)).expect("poshold");
        at(&mut c, 1000, Command::Arm).expect("arm");
        at(&mut c, 1500, Command::Shutdown).expect("accepted");
        assert!(!c.armed());
        assert_eq!(c.status(Time(1500)).last_refusal.as_deref(), Some(SHUTDOWN_DISARMED));
    }

    #[test]
    fn shutdown_disarmed_changes_nothing() {
        let mut c = ready(true);
        let before = c.mode();
        at(&mut c, 1000, Command::Shutdown).expect("accepted");
        assert!(!c.armed());
        assert_eq!(c.mode(), before);
        assert_eq!(c.status(Time(1000)).last_refusal, None);
    }
}
