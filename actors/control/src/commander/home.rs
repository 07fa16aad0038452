//! Home and the local frame it is placed in: where RTL returns, and what the geofence and
//! mission-relative altitudes are measured from.
//!
//! Home is the NED position where the vehicle armed, unless a ground station set it
//! (MAV_CMD_DO_SET_HOME): then it stays where it was put, as ArduPilot locks it and PX4 keeps a
//! manual home. As both do, home may be moved in flight; RTL then heads for the new home (the
//! commander restarts it). A position it cannot place is refused: no estimator origin yet, no
//! position estimate for "here", a point off the globe, or one farther from the origin than
//! [`MAX_FROM_ORIGIN_M`]. Rally points, when they come, are more places of the same kind.

use kestrel_proto::Time;
use kestrel_proto::geo::{Geodetic, LocalFrame};
use kestrel_proto::messages::{self, AltitudeFrame, FlightMode, MissionPoint, NavState};
use nalgebra::Vector3;

use super::Commander;
use super::arming::{Refusal, refuse};
use super::mission_runner::resolve;

/// Farthest home may be from the estimator's origin, horizontally or vertically (m): beyond
/// this the local NED frame no longer describes the ground (ArduPilot refuses a home 50 km
/// from its EKF origin too).
pub const MAX_FROM_ORIGIN_M: f64 = 50_000.0;

/// Home and the estimator's NED frame (fixed by its first origin).
#[derive(Debug, Default)]
pub(crate) struct Home {
    /// The estimator's first origin as a local frame; `None` until it has one.
    frame: Option<LocalFrame>,
    /// Home, NED from the estimator's origin (m).
    ned: Option<Vector3<f64>>,
    /// Home was set by a ground station: arming no longer moves it (ArduPilot's locked home).
    locked: bool,
    /// Moves of home so far (`Home::revision` in the status).
    revision: u32,
}

impl Home {
    /// The local frame of the estimator's origin, once it has one.
    pub fn frame(&self) -> Option<LocalFrame> {
        self.frame
    }

    /// Takes the estimator's origin as the frame if there is none yet; the new frame when it
    /// was taken now (the geofence is placed in it once).
    pub fn on_origin(&mut self, origin: Option<Geodetic>) -> Option<LocalFrame> {
        if self.frame.is_some() {
            return None;
        }
        self.frame = origin.map(LocalFrame::new);
        self.frame
    }

    /// Home, NED from the estimator's origin (m); set at arming or by a ground station.
    pub fn ned(&self) -> Option<Vector3<f64>> {
        self.ned
    }

    /// Home, or the vehicle's own position at `nav` while there is none (m, NED).
    pub fn or_here(&self, nav: &NavState) -> Vector3<f64> {
        self.ned.unwrap_or_else(|| Vector3::from(nav.position_ned_m))
    }

    /// Height of the vehicle at `nav` above home (m).
    pub fn height_m(&self, nav: &NavState) -> f64 {
        self.or_here(nav).z - nav.position_ned_m[2]
    }

    /// The vehicle armed at `position` (`None` without a fresh one): home moves there unless a
    /// ground station locked it.
    pub fn on_arming(&mut self, position: Option<Vector3<f64>>) {
        if !self.locked {
            self.ned = position;
            self.revision += 1;
        }
    }

    /// Places home at the vehicle (`point` `None`, `here` its fresh position) or at `point`,
    /// and locks it; refused, with the reason, when it cannot be placed.
    pub fn set(
        &mut self,
        here: Option<Vector3<f64>>,
        point: Option<MissionPoint>,
    ) -> Result<Vector3<f64>, Refusal> {
        let Some(frame) = self.frame else {
            return refuse("set home refused: the estimator has no origin yet");
        };
        let home = match point {
            None => here.ok_or_else(|| Refusal("set home refused: no position estimate".into()))?,
            Some(p) => {
                if !(p.lat_deg.abs() <= 90.0 && p.lon_deg.abs() <= 180.0 && p.alt_m.is_finite()) {
                    return refuse(format!(
                        "set home refused: {} {} {} m is not a position",
                        p.lat_deg, p.lon_deg, p.alt_m
                    ));
                }
                let old = match (p.frame, self.ned) {
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
        self.ned = Some(home);
        self.locked = true;
        self.revision += 1;
        Ok(home)
    }

    /// Home as the status reports it.
    pub fn status(&self) -> Option<messages::Home> {
        self.ned.map(|h| messages::Home { position_ned_m: [h.x, h.y, h.z], revision: self.revision })
    }
}

impl Commander {
    /// MAV_CMD_DO_SET_HOME: moves home to the vehicle's position (`point` `None`) or to
    /// `point`; RTL under way starts over towards the new home.
    pub(super) fn set_home(&mut self, now: Time, point: Option<MissionPoint>) -> Result<(), Refusal> {
        let here = self
            .fresh_nav(now)
            .filter(|n| n.valid.horizontal_position && n.valid.vertical_position)
            .map(|n| Vector3::from(n.position_ned_m));
        let home = self.home.set(here, point)?;
        tracing::info!(north_m = home.x, east_m = home.y, down_m = home.z, "home set");
        if self.armed && self.mode == FlightMode::ReturnToLaunch {
            // Start RTL over: climb, then return to the new home rather than land at the old.
            self.enter(FlightMode::ReturnToLaunch);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ORIGIN: Geodetic = Geodetic { lat_deg: 6.7971, lon_deg: 79.9017, alt_m: 20.0 };

    fn point(north_m: f64, alt_m: f64, frame: AltitudeFrame) -> MissionPoint {
        MissionPoint { lat_deg: ORIGIN.lat_deg + north_m / 111_000.0, lon_deg: ORIGIN.lon_deg, alt_m, frame }
    }

    #[test]
    fn the_first_origin_fixes_the_frame_and_later_ones_do_not_move_it() {
        let mut home = Home::default();
        assert_eq!(home.on_origin(None), None);
        assert!(home.on_origin(Some(ORIGIN)).is_some(), "the first origin is taken");
        let moved = Geodetic { lat_deg: 7.0, ..ORIGIN };
        assert_eq!(home.on_origin(Some(moved)), None, "a later origin is not");
        assert_eq!(home.frame().map(|f| f.home()), Some(ORIGIN));
    }

    #[test]
    fn arming_moves_an_unlocked_home_and_a_set_one_stays() {
        let mut home = Home::default();
        home.on_arming(Some(Vector3::new(1.0, 2.0, -3.0)));
        assert_eq!(home.ned(), Some(Vector3::new(1.0, 2.0, -3.0)));
        assert_eq!(home.status().map(|h| h.revision), Some(1));
        home.on_origin(Some(ORIGIN));
        let set = home.set(Some(Vector3::new(5.0, 0.0, -1.0)), None).expect("placed");
        assert_eq!(set, Vector3::new(5.0, 0.0, -1.0));
        home.on_arming(Some(Vector3::zeros()));
        assert_eq!(home.ned(), Some(set), "a home a ground station set is locked");
        assert_eq!(home.status().map(|h| h.revision), Some(2), "arming did not move it");
    }

    #[test]
    fn set_refuses_without_a_frame_a_position_or_a_place_on_the_globe() {
        let mut home = Home::default();
        let r = home.set(Some(Vector3::zeros()), None).expect_err("no frame");
        assert!(r.0.contains("no origin"), "{r}");
        home.on_origin(Some(ORIGIN));
        assert!(home.set(None, None).expect_err("no position").0.contains("no position estimate"));
        let relative = point(10.0, 5.0, AltitudeFrame::RelativeHome);
        assert!(home.set(None, Some(relative)).expect_err("no home").0.contains("not yet set"));
        let off = MissionPoint { lat_deg: 91.0, ..point(0.0, 5.0, AltitudeFrame::Amsl) };
        assert!(home.set(None, Some(off)).expect_err("off the globe").0.contains("is not a position"));
        let far = point(60_000.0, 20.0, AltitudeFrame::Amsl);
        assert!(home.set(None, Some(far)).expect_err("far").0.contains("from the origin"));
        assert_eq!(home.ned(), None, "nothing refused moved home");
    }

    #[test]
    fn height_is_measured_from_home_or_from_the_vehicle_without_one() {
        let mut nav = crate::commander::tests::nav(Time(1000), -7.0, true);
        let mut home = Home::default();
        assert_eq!(home.height_m(&nav), 0.0);
        home.on_arming(Some(Vector3::new(0.0, 0.0, -2.0)));
        assert_eq!(home.height_m(&nav), 5.0);
        nav.position_ned_m[2] = -1.0;
        assert_eq!(home.height_m(&nav), -1.0);
    }
}
