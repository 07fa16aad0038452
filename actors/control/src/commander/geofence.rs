//! The geofence: a cylinder around home (`max_radius_m`, `max_altitude_m`) and an optional
//! inclusion polygon, placed in the estimator's NED frame once it has an origin, and switched
//! by MAV_CMD_DO_FENCE_ENABLE. A breach while armed is the `GeofenceBreach` failsafe; outside
//! it the vehicle does not arm, and `feasibility` refuses targets beyond it.
//!
//! The polygon is held as one list of vertices: fences a ground station uploads (several
//! inclusion and exclusion polygons, circles) belong here beside it.

use kestrel_proto::geo::LocalFrame;
use kestrel_proto::messages::NavState;
use nalgebra::Vector3;

use super::params::GeofenceParams;

/// Whether the fence is on, and its polygon in the local frame.
#[derive(Debug)]
pub(crate) struct Geofence {
    /// A breach triggers its failsafe (MAV_CMD_DO_FENCE_ENABLE switches it); on at boot.
    enabled: bool,
    /// The inclusion polygon's vertices, north/east (m) from the estimator's origin; empty
    /// before the origin is known, or for no polygon.
    polygon_ned: Vec<[f64; 2]>,
}

impl Default for Geofence {
    fn default() -> Geofence {
        Geofence { enabled: true, polygon_ned: Vec::new() }
    }
}

impl Geofence {
    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// MAV_CMD_DO_FENCE_ENABLE. Accepted in flight, as ArduPilot does: switching it off clears
    /// a breach's failsafe cause but not the RTL it started; switching it on while outside
    /// breaches at once.
    pub fn set_enabled(&mut self, enabled: bool) {
        if enabled != self.enabled {
            tracing::info!(enabled, "geofence");
        }
        self.enabled = enabled;
    }

    /// Places the configured polygon (`[lat_deg, lon_deg]` vertices) in `frame`, at the
    /// origin's altitude.
    pub fn place(&mut self, frame: &LocalFrame, polygon_deg: &[[f64; 2]]) {
        let alt_m = frame.home().alt_m;
        self.polygon_ned = polygon_deg
            .iter()
            .map(|&[lat_deg, lon_deg]| {
                let ned = frame.to_ned(kestrel_proto::geo::Geodetic { lat_deg, lon_deg, alt_m });
                [ned[0], ned[1]]
            })
            .collect();
    }

    /// The polygon's vertices, north/east (m); empty for none.
    pub fn polygon_ned(&self) -> &[[f64; 2]] {
        &self.polygon_ned
    }

    /// The vehicle at `nav` is outside the fence around `home` (NED, m), whether or not the
    /// fence is on; never without a horizontal and vertical position.
    pub fn outside(&self, nav: &NavState, home: &Vector3<f64>, limits: &GeofenceParams) -> bool {
        if !(nav.valid.horizontal_position && nav.valid.vertical_position) {
            return false;
        }
        let p = Vector3::from(nav.position_ned_m);
        let radius = (p.x - home.x).hypot(p.y - home.y);
        let height = home.z - p.z;
        radius > limits.max_radius_m
            || height > limits.max_altitude_m
            || !inside_polygon(&self.polygon_ned, p.x, p.y)
    }
}

/// Even-odd ray casting; an empty polygon contains everything.
pub(crate) fn inside_polygon(vertices: &[[f64; 2]], north: f64, east: f64) -> bool {
    if vertices.len() < 3 {
        return true;
    }
    let mut inside = false;
    let mut j = vertices.len() - 1;
    for i in 0..vertices.len() {
        let ([ni, ei], [nj, ej]) = (vertices[i], vertices[j]);
        if (ei > east) != (ej > east) && north < (nj - ni) * (east - ei) / (ej - ei) + ni {
            inside = !inside;
        }
        j = i;
    }
    inside
}

#[cfg(test)]
mod tests {
    use kestrel_proto::Time;
    use kestrel_proto::geo::Geodetic;

    use super::*;
    use crate::commander::tests::nav;

    const ORIGIN: Geodetic = Geodetic { lat_deg: 6.7971, lon_deg: 79.9017, alt_m: 20.0 };

    fn at(north_m: f64, east_m: f64, down_m: f64) -> NavState {
        let mut n = nav(Time(1000), down_m, true);
        n.position_ned_m[0] = north_m;
        n.position_ned_m[1] = east_m;
        n
    }

    #[test]
    fn the_polygon_is_placed_in_the_frame_it_is_given() {
        let frame = LocalFrame::new(ORIGIN);
        let mut fence = Geofence::default();
        // About 111 m a degree of latitude: 0.001° north is about 111 m north.
        fence.place(&frame, &[[ORIGIN.lat_deg + 0.001, ORIGIN.lon_deg], [ORIGIN.lat_deg, ORIGIN.lon_deg]]);
        let [[n0, e0], [n1, e1]] = [fence.polygon_ned()[0], fence.polygon_ned()[1]];
        assert!((n0 - 110.6).abs() < 0.5 && e0.abs() < 1e-6, "{n0} {e0}");
        assert!(n1.abs() < 1e-6 && e1.abs() < 1e-6);
    }

    #[test]
    fn the_cylinder_and_the_polygon_each_bound_and_no_position_never_breaches() {
        let frame = LocalFrame::new(ORIGIN);
        let (d, limits) = (0.001, GeofenceParams::default());
        let mut fence = Geofence::default();
        let home = Vector3::zeros();
        assert!(!fence.outside(&at(299.0, 0.0, -119.0), &home, &limits));
        assert!(fence.outside(&at(301.0, 0.0, -10.0), &home, &limits), "radius");
        assert!(fence.outside(&at(0.0, 0.0, -121.0), &home, &limits), "altitude");
        let square =
            [[-d, -d], [d, -d], [d, d], [-d, d]].map(|[n, e]| [ORIGIN.lat_deg + n, ORIGIN.lon_deg + e]);
        fence.place(&frame, &square);
        assert!(!fence.outside(&at(100.0, 0.0, -10.0), &home, &limits));
        assert!(fence.outside(&at(120.0, 0.0, -10.0), &home, &limits), "polygon");
        let mut lost = at(500.0, 0.0, -10.0);
        lost.valid.horizontal_position = false;
        assert!(!fence.outside(&lost, &home, &limits), "no position: no breach");
    }

    #[test]
    fn the_switch_is_on_at_boot_and_follows_the_command() {
        let mut fence = Geofence::default();
        assert!(fence.enabled());
        fence.set_enabled(false);
        assert!(!fence.enabled());
        fence.set_enabled(true);
        assert!(fence.enabled());
    }
}
