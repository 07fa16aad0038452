//! The geometry of an uploaded fence (`FencePlan`): its polygons and circles placed in the
//! estimator's NED frame, and whether a north/east point (m) breaches them. As ArduCopter's
//! `AC_PolyFence_loader::breached`: a point breaches when it is outside any inclusion zone or
//! inside any exclusion zone, so the inclusion zones bound together (their intersection). A
//! point on an edge counts as inside the zone (tests in this file hold it).

use kestrel_proto::geo::{Geodetic, LocalFrame};
use kestrel_proto::messages::{FenceKind, FenceZone};

/// One zone in the local frame, north/east (m) from the estimator's origin.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum ZoneNed {
    Polygon { kind: FenceKind, vertices: Vec<[f64; 2]> },
    Circle { kind: FenceKind, center: [f64; 2], radius_m: f64 },
}

impl ZoneNed {
    /// `zone` placed in `frame` at the origin's altitude.
    pub fn place(zone: &FenceZone, frame: &LocalFrame) -> ZoneNed {
        let alt_m = frame.home().alt_m;
        let ne = |[lat_deg, lon_deg]: [f64; 2]| {
            let ned = frame.to_ned(Geodetic { lat_deg, lon_deg, alt_m });
            [ned[0], ned[1]]
        };
        match zone {
            FenceZone::Polygon { kind, vertices_deg } => {
                ZoneNed::Polygon { kind: *kind, vertices: vertices_deg.iter().copied().map(ne).collect() }
            }
            FenceZone::Circle { kind, center_deg, radius_m } => {
                ZoneNed::Circle { kind: *kind, center: ne(*center_deg), radius_m: *radius_m }
            }
        }
    }

    /// The point is inside the zone or on its edge.
    pub fn contains(&self, north: f64, east: f64) -> bool {
        match self {
            ZoneNed::Polygon { vertices, .. } => {
                inside_polygon(vertices, north, east) || on_edge(vertices, north, east)
            }
            ZoneNed::Circle { center, radius_m, .. } => {
                (north - center[0]).hypot(east - center[1]) <= *radius_m
            }
        }
    }

    fn kind(&self) -> FenceKind {
        match self {
            ZoneNed::Polygon { kind, .. } | ZoneNed::Circle { kind, .. } => *kind,
        }
    }

    /// The point breaches this zone: outside an inclusion zone, or strictly inside an exclusion
    /// zone (its edge is allowed, as an inclusion zone's is).
    pub fn breached_by(&self, north: f64, east: f64) -> bool {
        match self.kind() {
            FenceKind::Inclusion => !self.contains(north, east),
            FenceKind::Exclusion => self.contains(north, east) && !self.on_boundary(north, east),
        }
    }

    fn on_boundary(&self, north: f64, east: f64) -> bool {
        match self {
            ZoneNed::Polygon { vertices, .. } => on_edge(vertices, north, east),
            ZoneNed::Circle { center, radius_m, .. } => {
                ((north - center[0]).hypot(east - center[1]) - radius_m).abs() < EDGE_M
            }
        }
    }
}

/// Any zone breached at the point.
pub(crate) fn breached(zones: &[ZoneNed], north: f64, east: f64) -> bool {
    zones.iter().any(|z| z.breached_by(north, east))
}

/// How near to an edge counts as on it (m): far below any position estimate's error.
const EDGE_M: f64 = 1e-6;

/// Even-odd ray casting; an empty polygon (fewer than 3 vertices) contains everything.
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

/// The point lies within [`EDGE_M`] of one of the polygon's edges.
fn on_edge(vertices: &[[f64; 2]], north: f64, east: f64) -> bool {
    vertices.len() >= 3
        && (0..vertices.len()).any(|i| {
            let (a, b) = (vertices[i], vertices[(i + 1) % vertices.len()]);
            distance_to_segment(a, b, [north, east]) < EDGE_M
        })
}

/// Distance (m) from `p` to the segment `a`–`b`.
fn distance_to_segment(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 { (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
    (p[0] - (a[0] + t * dx)).hypot(p[1] - (a[1] + t * dy))
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    fn square(kind: FenceKind, half_m: f64) -> ZoneNed {
        let h = half_m;
        ZoneNed::Polygon { kind, vertices: vec![[-h, -h], [h, -h], [h, h], [-h, h]] }
    }

    #[test]
    fn inclusion_zones_bound_together_and_exclusion_zones_keep_out() {
        let zones = [
            square(FenceKind::Inclusion, 100.0),
            ZoneNed::Circle { kind: FenceKind::Inclusion, center: [50.0, 0.0], radius_m: 100.0 },
            ZoneNed::Circle { kind: FenceKind::Exclusion, center: [50.0, 50.0], radius_m: 10.0 },
        ];
        assert!(!breached(&zones, 0.0, 0.0));
        // Inside the square, outside the inclusion circle: the intersection bounds.
        assert!(breached(&zones, -80.0, -80.0));
        // Inside both inclusion zones, inside the exclusion circle.
        assert!(breached(&zones, 52.0, 48.0));
        assert!(!breached(&zones, 50.0, 61.0));
        assert!(!breached(&[], 1e6, -1e6), "no zones, no breach");
    }

    #[test]
    fn edges_count_as_inside_for_both_kinds() {
        let inc = square(FenceKind::Inclusion, 10.0);
        let exc = square(FenceKind::Exclusion, 10.0);
        for p in [[10.0, 0.0], [-10.0, 3.0], [10.0, 10.0], [0.0, -10.0]] {
            assert!(!inc.breached_by(p[0], p[1]), "{p:?} on the inclusion edge");
            assert!(!exc.breached_by(p[0], p[1]), "{p:?} on the exclusion edge");
        }
        let circle = ZoneNed::Circle { kind: FenceKind::Exclusion, center: [0.0, 0.0], radius_m: 5.0 };
        assert!(!circle.breached_by(5.0, 0.0));
        assert!(circle.breached_by(4.99, 0.0));
    }

    #[test]
    fn a_concave_polygon_excludes_its_notch() {
        // A U open to the north: the notch between the arms is outside.
        let u = ZoneNed::Polygon {
            kind: FenceKind::Inclusion,
            vertices: vec![
                [0.0, 0.0],
                [0.0, 30.0],
                [30.0, 30.0],
                [30.0, 20.0],
                [10.0, 20.0],
                [10.0, 10.0],
                [30.0, 10.0],
                [30.0, 0.0],
            ],
        };
        assert!(!u.breached_by(5.0, 15.0), "base");
        assert!(!u.breached_by(20.0, 5.0), "west arm");
        assert!(u.breached_by(20.0, 15.0), "notch");
    }

    /// A convex polygon as its vertices, counter-clockwise in (north, east), from angles.
    fn convex(radius: f64, angles: &[f64]) -> Vec<[f64; 2]> {
        let mut a = angles.to_vec();
        a.sort_by(f64::total_cmp);
        a.dedup_by(|x, y| (*x - *y).abs() < 1e-3);
        a.iter().map(|t| [radius * t.cos(), radius * t.sin()]).collect()
    }

    /// The independent reference: inside a convex counter-clockwise polygon is on the left of
    /// (or on) every edge.
    fn half_planes(v: &[[f64; 2]], p: [f64; 2]) -> Option<bool> {
        let mut inside = true;
        for i in 0..v.len() {
            let (a, b) = (v[i], v[(i + 1) % v.len()]);
            let cross = (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
            let len = (b[0] - a[0]).hypot(b[1] - a[1]);
            if (cross / len).abs() < 1e-3 {
                return None; // too near an edge for either to be the judge
            }
            inside &= cross > 0.0;
        }
        Some(inside)
    }

    proptest! {
        #[test]
        fn ray_casting_agrees_with_half_planes_on_convex_polygons(
            radius in 5.0f64..500.0,
            angles in prop::collection::vec(0.0f64..std::f64::consts::TAU, 3..12),
            pn in -600.0f64..600.0,
            pe in -600.0f64..600.0,
        ) {
            let v = convex(radius, &angles);
            prop_assume!(v.len() >= 3);
            // Degenerate (all vertices within a half circle of small spread) polygons still
            // are convex; only a zero area one has no inside to compare.
            let area: f64 = (0..v.len()).map(|i| {
                let (a, b) = (v[i], v[(i + 1) % v.len()]);
                a[0] * b[1] - b[0] * a[1]
            }).sum();
            prop_assume!(area > 1.0);
            if let Some(expected) = half_planes(&v, [pn, pe]) {
                let zone = ZoneNed::Polygon { kind: FenceKind::Inclusion, vertices: v.clone() };
                prop_assert_eq!(zone.contains(pn, pe), expected);
                let exclusion = ZoneNed::Polygon { kind: FenceKind::Exclusion, vertices: v };
                prop_assert_eq!(exclusion.breached_by(pn, pe), expected);
            }
        }

        #[test]
        fn a_circle_holds_exactly_the_points_within_its_radius(
            cn in -100.0f64..100.0, ce in -100.0f64..100.0, r in 1.0f64..300.0,
            bearing in 0.0f64..std::f64::consts::TAU, d in 0.0f64..600.0,
        ) {
            prop_assume!((d - r).abs() > 1e-6);
            let (pn, pe) = (cn + d * bearing.cos(), ce + d * bearing.sin());
            let inc = ZoneNed::Circle { kind: FenceKind::Inclusion, center: [cn, ce], radius_m: r };
            let exc = ZoneNed::Circle { kind: FenceKind::Exclusion, center: [cn, ce], radius_m: r };
            prop_assert_eq!(inc.breached_by(pn, pe), d > r);
            prop_assert_eq!(exc.breached_by(pn, pe), d < r);
        }
    }
}
