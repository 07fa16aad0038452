//! Feasibility of what a ground station asks the vehicle to fly: a mission on upload and again
//! when it starts (PX4's `MissionFeasibilityChecker`), and a GUIDED position or velocity target
//! when it arrives. A target that would take the vehicle below home, out of the geofence or
//! farther than the configured distances is refused with the item and the reason, so the
//! ground station says what to fix instead of the vehicle flying into the ground.

use kestrel_proto::geo::LocalFrame;
use kestrel_proto::messages::{Mission, MissionItem};
use nalgebra::Vector3;

use super::Commander;
use super::arming::Refusal;
use super::geofence::Geofence;
use super::mission_runner::resolve;
use super::params::{FeasibilityParams, GeofenceParams};

/// Where the checks measure from, in NED metres from the estimator's origin.
pub(crate) struct Place<'a> {
    pub frame: LocalFrame,
    pub home: Vector3<f64>,
    pub vehicle: Vector3<f64>,
    /// The geofence while it is on; `None` off.
    pub fence: Option<&'a Geofence>,
}

/// What can be checked without knowing where the vehicle is ([`Mission::check_fields`], which
/// the link runs before it acknowledges an upload).
pub(crate) fn check_fields(mission: &Mission) -> Result<(), Refusal> {
    mission.check_fields().map_err(Refusal)
}

/// The whole check, once home and the NED frame are known: every point flown is at least
/// `min_height_m` above home (landing points excepted: their altitude is not flown), inside the
/// geofence when it is on, within `max_distance_m` of home, and the first one within
/// `first_distance_m` of the vehicle (PX4's `MIS_DIST_1WP`).
pub(crate) fn check_mission(
    mission: &Mission,
    place: &Place<'_>,
    limits: &FeasibilityParams,
    fence: &GeofenceParams,
) -> Result<(), Refusal> {
    check_fields(mission)?;
    let mut first = true;
    for (i, item) in mission.items.iter().enumerate() {
        let (point, flown_height) = match item {
            MissionItem::Takeoff { point } | MissionItem::Waypoint { point, .. } => (point, true),
            MissionItem::Land { point } => (point, false),
            _ => continue,
        };
        let ned = resolve(point, &place.frame, &place.home, &place.vehicle);
        let has_xy = point.lat_deg.is_finite() && point.lon_deg.is_finite();
        let why = check_point(&ned, flown_height, place, limits, fence).or_else(|| {
            let from_vehicle = (ned.x - place.vehicle.x).hypot(ned.y - place.vehicle.y);
            (first && has_xy && from_vehicle > limits.first_distance_m).then(|| {
                format!(
                    "{from_vehicle:.0} m from the vehicle, first item at most {:.0} m",
                    limits.first_distance_m
                )
            })
        });
        if let Some(why) = why {
            return Err(Refusal(format!("mission item {}: {why}", i + 1)));
        }
        first &= !has_xy;
    }
    Ok(())
}

/// Why a NED point (m) cannot be flown to, `None` when it can; `flown_height` false for a
/// landing point, whose height is the ground's.
pub(crate) fn check_point(
    ned: &Vector3<f64>,
    flown_height: bool,
    place: &Place<'_>,
    limits: &FeasibilityParams,
    fence: &GeofenceParams,
) -> Option<String> {
    if !ned.iter().all(|v| v.is_finite()) {
        return Some("position is not a number".into());
    }
    let height = place.home.z - ned.z;
    let distance = (ned.x - place.home.x).hypot(ned.y - place.home.y);
    if flown_height && height < limits.min_height_m {
        return Some(format!("{height:.1} m above home, at least {:.1} m", limits.min_height_m));
    }
    if distance > limits.max_distance_m {
        return Some(format!("{distance:.0} m from home, at most {:.0} m", limits.max_distance_m));
    }
    if flown_height && height > limits.max_distance_m {
        return Some(format!("{height:.0} m above home, at most {:.0} m", limits.max_distance_m));
    }
    if let Some(why) = place.fence.and_then(|f| f.target_refused(ned, &place.home, fence, flown_height)) {
        return Some(why);
    }
    None
}

impl Commander {
    /// Home, the frame and the vehicle's position, once the estimator has an origin and a
    /// position (before that nothing can be placed and a mission waits for its start check).
    pub(crate) fn place(&self) -> Option<Place<'_>> {
        let (frame, nav) = (self.home.frame()?, self.nav.latest()?);
        let vehicle = Vector3::from(nav.position_ned_m);
        Some(Place {
            frame,
            home: self.home.ned().unwrap_or(vehicle),
            vehicle,
            fence: self.geofence.enabled().then_some(&self.geofence),
        })
    }

    /// The mission check against what the commander knows now; `Ok` when nothing can be placed
    /// yet (the start check, which needs a position anyway, judges it then).
    pub(crate) fn mission_feasible(&self, mission: &Mission) -> Result<(), Refusal> {
        match self.place() {
            Some(place) => check_mission(mission, &place, &self.params.feasibility, &self.params.geofence),
            None => check_fields(mission),
        }
    }

    /// Why a GUIDED position target (NED, m) is refused, `None` when it may be flown.
    pub(crate) fn guided_position_refused(&self, target: &Vector3<f64>) -> Option<String> {
        let Some(place) = self.place() else { return Some("no position estimate".into()) };
        check_point(target, true, &place, &self.params.feasibility, &self.params.geofence)
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::Time;
    use kestrel_proto::geo::Geodetic;
    use kestrel_proto::messages::{AltitudeFrame, MAX_MISSION_ITEMS, MissionPoint};

    use super::*;

    const HOME: Geodetic = Geodetic { lat_deg: 6.7971, lon_deg: 79.9017, alt_m: 20.0 };

    fn waypoint(north_m: f64, alt_m: f64) -> MissionItem {
        let lat_deg = HOME.lat_deg + north_m / 111_000.0;
        MissionItem::Waypoint {
            point: MissionPoint { lat_deg, lon_deg: HOME.lon_deg, alt_m, frame: AltitudeFrame::RelativeHome },
            acceptance_radius_m: 2.0,
            hold_s: 0.0,
        }
    }

    fn mission(items: Vec<MissionItem>) -> Mission {
        Mission { time: Time::ZERO, items, cruise_speed_m_s: 5.0 }
    }

    fn check(items: Vec<MissionItem>, fence_enabled: bool) -> Result<(), Refusal> {
        let frame = LocalFrame::new(HOME);
        let geofence = Geofence::default();
        let fence = fence_enabled.then_some(&geofence);
        let place = Place { frame, home: Vector3::zeros(), vehicle: Vector3::zeros(), fence };
        check_mission(&mission(items), &place, &FeasibilityParams::default(), &GeofenceParams::default())
    }

    fn reason(r: Result<(), Refusal>) -> String {
        r.expect_err("refused").0
    }

    #[test]
    fn a_waypoint_below_home_or_the_least_height_is_refused_by_item() {
        assert_eq!(check(vec![waypoint(10.0, 10.0), waypoint(20.0, 10.0)], true), Ok(()));
        let r = reason(check(vec![waypoint(10.0, 10.0), waypoint(20.0, -500.0)], true));
        assert!(r.starts_with("mission item 2: -500.0 m above home"), "{r}");
        let r = reason(check(vec![waypoint(10.0, 0.5)], true));
        assert!(r.starts_with("mission item 1:"), "{r}");
    }

    #[test]
    fn a_landing_point_needs_no_height_but_must_be_inside_the_fence() {
        let land = |north_m: f64| MissionItem::Land {
            point: MissionPoint {
                lat_deg: HOME.lat_deg + north_m / 111_000.0,
                lon_deg: HOME.lon_deg,
                alt_m: 0.0,
                frame: AltitudeFrame::RelativeHome,
            },
        };
        assert_eq!(check(vec![waypoint(10.0, 10.0), land(20.0)], true), Ok(()));
        let r = reason(check(vec![waypoint(10.0, 10.0), land(400.0)], true));
        assert!(r.contains("item 2") && r.contains("geofence"), "{r}");
    }

    #[test]
    fn the_fence_the_distance_limit_and_the_first_item_distance_each_refuse() {
        let r = reason(check(vec![waypoint(10.0, 130.0)], true));
        assert!(r.contains("above the 120 m geofence"), "{r}");
        assert_eq!(check(vec![waypoint(10.0, 130.0)], false), Ok(()), "fence off: height is not limited");
        let r = reason(check(vec![waypoint(350.0, 10.0)], true));
        assert!(r.contains("outside the 300 m geofence"), "{r}");
        let r = reason(check(vec![waypoint(950.0, 10.0)], false));
        assert!(r.contains("first item at most 900 m"), "{r}");
        let r = reason(check(vec![waypoint(500.0, 10.0), waypoint(1500.0, 10.0)], false));
        assert!(r.contains("item 2") && r.contains("at most 1000 m"), "{r}");
        let r = reason(check(vec![waypoint(10.0, 1e30)], false));
        assert!(r.contains("above home, at most 1000 m"), "fence off, still bounded: {r}");
    }

    #[test]
    fn numbers_that_are_not_numbers_and_too_many_items_are_refused() {
        let nan_alt = waypoint(10.0, f64::NAN);
        assert!(reason(check(vec![waypoint(5.0, 10.0), nan_alt], true)).starts_with("mission item 2"));
        let far = MissionItem::Waypoint {
            point: MissionPoint {
                lat_deg: 95.0,
                lon_deg: 0.0,
                alt_m: 10.0,
                frame: AltitudeFrame::RelativeHome,
            },
            acceptance_radius_m: 2.0,
            hold_s: 0.0,
        };
        assert!(reason(check(vec![far], true)).contains("out of range"));
        let speed = MissionItem::ChangeSpeed { speed_m_s: f64::INFINITY };
        assert!(reason(check(vec![speed], true)).contains("speed"));
        let many = vec![waypoint(10.0, 10.0); MAX_MISSION_ITEMS + 1];
        assert!(reason(check_fields(&mission(many))).contains("at most 1000"));
        let mut m = mission(vec![waypoint(10.0, 10.0)]);
        m.cruise_speed_m_s = f64::NAN;
        assert!(check_fields(&m).is_err());
    }
}
