//! MAV_CMD_DO_SET_HOME: moving home, where RTL returns and what the geofence and
//! mission-relative altitudes are measured from.
//!
//! As PX4 and ArduPilot do, home may be moved in flight; RTL then heads for the new home. A home
//! set this way is kept when the vehicle arms again (ArduPilot locks it; PX4 keeps a manual home).
//! A position it cannot place is refused: no estimator origin yet, no position estimate for
//! "here", a point off the globe, or one farther from the origin than [`MAX_FROM_ORIGIN_M`].

use kestrel_proto::Time;
use kestrel_proto::messages::{AltitudeFrame, FlightMode, MissionPoint};
use nalgebra::Vector3;

use super::Commander;
use super::arming::{Refusal, refuse};
use super::mission_runner::resolve;

/// Farthest home may be from the estimator's origin, horizontally or vertically (m): beyond
/// this the local NED frame no longer describes the ground (ArduPilot refuses a home 50 km
/// from its EKF origin too).
pub const MAX_FROM_ORIGIN_M: f64 = 50_000.0;

impl Commander {
    /// Moves home to the vehicle's position (`point` `None`) or to `point`.
    pub(super) fn set_home(&mut self, now: Time, point: Option<MissionPoint>) -> Result<(), Refusal> {
        let Some(frame) = self.frame else {
            return refuse("set home refused: the estimator has no origin yet");
        };
        let here = self
            .fresh_nav(now)
            .filter(|n| n.valid.horizontal_position && n.valid.vertical_position)
            .map(|n| Vector3::from(n.position_ned_m));
        let home = match point {
            None => here.ok_or_else(|| Refusal("set home refused: no position estimate".into()))?,
            Some(p) => {
                if !(p.lat_deg.abs() <= 90.0 && p.lon_deg.abs() <= 180.0 && p.alt_m.is_finite()) {
                    return refuse(format!(
                        "set home refused: {} {} {} m is not a position",
                        p.lat_deg, p.lon_deg, p.alt_m
                    ));
                }
                let old = match (p.frame, self.home_ned) {
                    (AltitudeFrame::RelativeHome, None) => {
                        return refuse("set home refused: altitude relative to a home not yet set");
                    }
                    (_, old) => old.unwrap_or_default(),
                };
                resolve(&p, &frame, &old, &old)
            }
        };
        if home.x.hypot(home.y) > MAX_FROM_ORIGIN_M || home.z.abs() > MAX_FROM_ORIGIN_M {
            return refuse(format!("set home refused: more than {MAX_FROM_ORIGIN_M} m from the origin"));
        }
        self.home_ned = Some(home);
        self.home_locked = true;
        self.home_revision += 1;
        tracing::info!(north_m = home.x, east_m = home.y, down_m = home.z, "home set");
        if self.armed && self.mode == FlightMode::ReturnToLaunch {
            // Start RTL over: climb, then return to the new home rather than land at the old.
            self.enter(FlightMode::ReturnToLaunch);
        }
        Ok(())
    }
}
