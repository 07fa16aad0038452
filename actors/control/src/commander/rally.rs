//! Rally points and where RTL returns: the nearest rally point or home, chosen as ArduCopter
//! chooses (`AP_Rally::calc_best_rally_or_home_location`, called when RTL starts):
//! * the rally point nearest the vehicle (horizontal distance) is the candidate; points at
//!   latitude and longitude 0 are skipped, as ArduPilot skips them;
//! * with `limit_km` > 0 (`RALLY_LIMIT_KM`), a nearest point farther than that from the vehicle
//!   is no candidate: a rally point left over from another field is never flown to;
//! * with `include_home` (`RALLY_INCL_HOME`) home counts as one more rally point and wins when it
//!   is no farther than the candidate; without it the candidate wins wherever home is.
//!
//! The return is flown at the highest of the RTL altitude, the rally point's altitude above home
//! and the vehicle's own (ArduCopter's `ModeRTL::compute_return_target`), then loiters and lands
//! at the target as at home. Tests: `tests::rally` and this file's own.

use kestrel_proto::geo::LocalFrame;
use kestrel_proto::messages::{MissionPoint, RallyPoints};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::Commander;
use super::arming::{Refusal, refuse};
use super::mission_runner::resolve;

/// `[rally]`: which rally point RTL may choose.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RallyParams {
    /// The nearest rally point is flown to only within this distance of the vehicle (km); 0 =
    /// no limit. ArduCopter's `RALLY_LIMIT_KM` and its default, 0.3 km.
    pub limit_km: f64,
    /// Home counts as a rally point (`RALLY_INCL_HOME`, default 1 on ArduCopter).
    pub include_home: bool,
}

impl Default for RallyParams {
    fn default() -> RallyParams {
        RallyParams { limit_km: 0.3, include_home: true }
    }
}

/// The rally points a ground station uploaded (none until it does).
#[derive(Debug, Default)]
pub(crate) struct Rally {
    points: Vec<MissionPoint>,
}

/// Where RTL returns to: NED from the estimator's origin (m), its down coordinate the altitude
/// the point asks to be reached at (home's own for home).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ReturnTarget {
    pub ned_m: Vector3<f64>,
    /// Index of the rally point chosen; `None` for home.
    pub rally: Option<usize>,
}

impl Rally {
    /// The points held.
    pub fn points(&self) -> &[MissionPoint] {
        &self.points
    }

    /// Where RTL from `pos` returns: home or a rally point placed in `frame` (home's altitude the
    /// reference of theirs). Without a frame no rally point can be placed: home.
    pub fn return_target(
        &self,
        params: &RallyParams,
        frame: Option<&LocalFrame>,
        home: &Vector3<f64>,
        pos: &Vector3<f64>,
    ) -> ReturnTarget {
        let home_target = ReturnTarget { ned_m: *home, rally: None };
        let Some(frame) = frame else { return home_target };
        let placed: Vec<Vector3<f64>> = self
            .points
            .iter()
            .map(|p| if p.lat_deg == 0.0 && p.lon_deg == 0.0 { None } else { Some(p) })
            .map(|p| p.map_or(Vector3::repeat(f64::NAN), |p| resolve(p, frame, home, pos)))
            .collect();
        choose(&placed, params, home, pos)
    }
}

/// Horizontal distance (m).
fn horizontal(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    (a.x - b.x).hypot(a.y - b.y)
}

/// The choice itself, on points already placed in NED (a NaN point is skipped).
pub(crate) fn choose(
    points: &[Vector3<f64>],
    params: &RallyParams,
    home: &Vector3<f64>,
    pos: &Vector3<f64>,
) -> ReturnTarget {
    let home_target = ReturnTarget { ned_m: *home, rally: None };
    let nearest = points
        .iter()
        .enumerate()
        .filter(|(_, p)| p.iter().all(|v| v.is_finite()))
        .map(|(i, p)| (i, horizontal(p, pos)))
        .min_by(|a, b| a.1.total_cmp(&b.1));
    let Some((i, distance)) = nearest else { return home_target };
    if params.limit_km > 0.0 && distance > params.limit_km * 1000.0 {
        return home_target;
    }
    if params.include_home && horizontal(home, pos) <= distance {
        return home_target;
    }
    ReturnTarget { ned_m: points[i], rally: Some(i) }
}

impl Commander {
    /// A ground station uploaded (or cleared) the rally points. An RTL under way keeps the
    /// target it chose when it started, as ArduCopter builds its path once.
    pub fn on_rally(&mut self, rally: RallyPoints) -> Result<(), Refusal> {
        if let Err(why) = rally.check_fields() {
            return self.refused(refuse(why));
        }
        tracing::info!(points = rally.points.len(), "rally points");
        self.rally.points = rally.points;
        Ok(())
    }

    /// Rally points held (a copy for tests and reports).
    pub fn rally_points(&self) -> &[MissionPoint] {
        self.rally.points()
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    fn v(n: f64, e: f64, d: f64) -> Vector3<f64> {
        Vector3::new(n, e, d)
    }

    const HOME: Vector3<f64> = Vector3::new(0.0, 0.0, 0.0);

    fn with(limit_km: f64, include_home: bool) -> RallyParams {
        RallyParams { limit_km, include_home }
    }

    #[test]
    fn the_nearest_rally_point_wins_over_a_farther_home() {
        let points = [v(200.0, 0.0, -20.0), v(100.0, 50.0, -10.0), v(-50.0, 0.0, -5.0)];
        // 120 m north, 40 m east: the second point is 14 m away, home 126 m.
        let t = choose(&points, &with(0.0, true), &HOME, &v(110.0, 40.0, -15.0));
        assert_eq!(t, ReturnTarget { ned_m: points[1], rally: Some(1) });
    }

    #[test]
    fn home_included_wins_when_it_is_nearer_and_not_otherwise() {
        let points = [v(100.0, 0.0, -10.0)];
        let pos = v(30.0, 0.0, -15.0);
        assert_eq!(choose(&points, &with(0.0, true), &HOME, &pos).rally, None);
        assert_eq!(choose(&points, &with(0.0, false), &HOME, &pos).rally, Some(0));
    }

    #[test]
    fn a_nearest_point_beyond_the_limit_is_ignored_and_zero_is_no_limit() {
        let points = [v(500.0, 0.0, -10.0)];
        let pos = v(900.0, 0.0, -15.0);
        // 400 m away: beyond 0.3 km, within 0.5 km, and any distance with no limit.
        assert_eq!(choose(&points, &with(0.3, false), &HOME, &pos).rally, None);
        assert_eq!(choose(&points, &with(0.5, false), &HOME, &pos).rally, Some(0));
        assert_eq!(choose(&points, &with(0.0, false), &HOME, &pos).rally, Some(0));
    }

    #[test]
    fn no_points_or_no_frame_is_home() {
        assert_eq!(choose(&[], &with(0.0, false), &HOME, &v(10.0, 0.0, 0.0)).rally, None);
        let rally = Rally {
            points: vec![MissionPoint {
                lat_deg: 6.8,
                lon_deg: 79.9,
                alt_m: 10.0,
                frame: kestrel_proto::messages::AltitudeFrame::RelativeHome,
            }],
        };
        let t = rally.return_target(&with(0.0, false), None, &HOME, &v(10.0, 0.0, 0.0));
        assert_eq!(t.rally, None);
    }

    #[test]
    fn a_point_at_latitude_and_longitude_zero_is_skipped() {
        let frame =
            LocalFrame::new(kestrel_proto::geo::Geodetic { lat_deg: 6.7971, lon_deg: 79.9017, alt_m: 20.0 });
        let point = |lat_deg, lon_deg| MissionPoint {
            lat_deg,
            lon_deg,
            alt_m: 10.0,
            frame: kestrel_proto::messages::AltitudeFrame::RelativeHome,
        };
        let rally = Rally { points: vec![point(0.0, 0.0), point(6.7981, 79.9017)] };
        let t = rally.return_target(&with(0.0, false), Some(&frame), &HOME, &v(0.0, 0.0, -5.0));
        assert_eq!(t.rally, Some(1));
        // 0.001° of latitude north, 10 m above home.
        assert!((t.ned_m.x - 110.6).abs() < 0.5 && t.ned_m.y.abs() < 0.01 && (t.ned_m.z + 10.0).abs() < 1e-9);
    }

    proptest! {
        /// Whatever the points, the target is home or the nearest point; the nearest point
        /// within the limit when home is not included; never a point beyond the limit.
        #[test]
        fn the_target_is_home_or_the_nearest_point_within_the_limit(
            raw in prop::collection::vec((-2000.0f64..2000.0, -2000.0f64..2000.0), 0..8),
            pos in (-2000.0f64..2000.0, -2000.0f64..2000.0),
            limit_km in 0.0f64..3.0,
            include_home in any::<bool>(),
        ) {
            let points: Vec<_> = raw.iter().map(|&(n, e)| v(n, e, -10.0)).collect();
            let pos = v(pos.0, pos.1, -20.0);
            let params = with(limit_km, include_home);
            let t = choose(&points, &params, &HOME, &pos);
            let nearest = points.iter().map(|p| horizontal(p, &pos)).fold(f64::INFINITY, f64::min);
            match t.rally {
                None => {
                    prop_assert_eq!(t.ned_m, HOME);
                    let in_limit = limit_km == 0.0 || nearest <= limit_km * 1000.0;
                    prop_assert!(!in_limit || include_home && horizontal(&HOME, &pos) <= nearest);
                }
                Some(i) => {
                    prop_assert_eq!(horizontal(&points[i], &pos), nearest);
                    prop_assert!(limit_km == 0.0 || nearest <= limit_km * 1000.0);
                    prop_assert!(!include_home || nearest < horizontal(&HOME, &pos));
                }
            }
        }
    }
}
