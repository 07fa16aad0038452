//! Obstacle geometry as the map figures need it: each obstacle's outline seen from above, the
//! horizontal distance from a point to that outline, and the heights it spans. Coordinates are
//! north/east (m) in the obstacle map's NED frame; heights are metres above the ground.

use std::f64::consts::TAU;

use kestrel_proto::messages::Obstacle;

/// Vertices of a cylinder's outline: fine enough that a 2 m tree on a 1280 px map looks round.
const CIRCLE_VERTICES: usize = 48;

/// What an obstacle is drawn as; each kind has its own colour and legend entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kind {
    Tree,
    Box,
    TexturedWall,
    /// A wall without texture: the stereo camera sees no disparity on it (thesis §4.2.3).
    PlainWall,
}

pub(crate) fn kind(obstacle: &Obstacle) -> Kind {
    match obstacle {
        Obstacle::Cylinder { .. } => Kind::Tree,
        Obstacle::Box { .. } => Kind::Box,
        Obstacle::Wall { textured: true, .. } => Kind::TexturedWall,
        Obstacle::Wall { textured: false, .. } => Kind::PlainWall,
    }
}

/// The obstacle's outline seen from above, as (north, east) vertices (m).
pub(crate) fn outline_ne_m(obstacle: &Obstacle) -> Vec<(f64, f64)> {
    match *obstacle {
        Obstacle::Cylinder { base_ne_m: [n, e], radius_m, .. } => (0..CIRCLE_VERTICES)
            .map(|i| {
                let (sin, cos) = (TAU * i as f64 / CIRCLE_VERTICES as f64).sin_cos();
                (n + radius_m * cos, e + radius_m * sin)
            })
            .collect(),
        _ => {
            let r = rectangle(obstacle);
            [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)]
                .iter()
                .map(|(a, b)| {
                    let (x, y) = (a * r.half_m.0, b * r.half_m.1);
                    (r.center_ne_m.0 + r.cos * x - r.sin * y, r.center_ne_m.1 + r.sin * x + r.cos * y)
                })
                .collect()
        }
    }
}

/// Horizontal distance (m) from `ne_m` (north, east) to the obstacle's outline; negative
/// inside it.
pub(crate) fn horizontal_distance_m(obstacle: &Obstacle, ne_m: (f64, f64)) -> f64 {
    if let Obstacle::Cylinder { base_ne_m: [n, e], radius_m, .. } = *obstacle {
        return (ne_m.0 - n).hypot(ne_m.1 - e) - radius_m;
    }
    let r = rectangle(obstacle);
    let (dn, de) = (ne_m.0 - r.center_ne_m.0, ne_m.1 - r.center_ne_m.1);
    let local = (r.cos * dn + r.sin * de, -r.sin * dn + r.cos * de);
    let q = (local.0.abs() - r.half_m.0, local.1.abs() - r.half_m.1);
    q.0.max(0.0).hypot(q.1.max(0.0)) + q.0.max(q.1).min(0.0)
}

/// Bottom and top of the obstacle (m above the ground).
pub(crate) fn heights_m(obstacle: &Obstacle) -> (f64, f64) {
    match *obstacle {
        Obstacle::Box { center_ned_m, size_m, .. } => {
            (-center_ned_m[2] - size_m[2] / 2.0, -center_ned_m[2] + size_m[2] / 2.0)
        }
        Obstacle::Cylinder { height_m, .. } | Obstacle::Wall { height_m, .. } => (0.0, height_m),
    }
}

/// A box's or a wall's outline: a rectangle turned about down.
struct Rectangle {
    center_ne_m: (f64, f64),
    /// Half extents along its own north and east axes (m).
    half_m: (f64, f64),
    /// Of the yaw, clockwise seen from above (north towards east).
    sin: f64,
    cos: f64,
}

fn rectangle(obstacle: &Obstacle) -> Rectangle {
    match *obstacle {
        Obstacle::Box { center_ned_m, size_m, yaw_deg } => {
            let (sin, cos) = yaw_deg.to_radians().sin_cos();
            Rectangle {
                center_ne_m: (center_ned_m[0], center_ned_m[1]),
                half_m: (size_m[0] / 2.0, size_m[1] / 2.0),
                sin,
                cos,
            }
        }
        Obstacle::Wall { from_ne_m, to_ne_m, thickness_m, .. } => {
            let along = (to_ne_m[0] - from_ne_m[0], to_ne_m[1] - from_ne_m[1]);
            let length = along.0.hypot(along.1);
            let (sin, cos) = if length > 0.0 { (along.1 / length, along.0 / length) } else { (0.0, 1.0) };
            Rectangle {
                center_ne_m: ((from_ne_m[0] + to_ne_m[0]) / 2.0, (from_ne_m[1] + to_ne_m[1]) / 2.0),
                half_m: (length / 2.0, thickness_m / 2.0),
                sin,
                cos,
            }
        }
        Obstacle::Cylinder { base_ne_m: [n, e], radius_m, .. } => {
            Rectangle { center_ne_m: (n, e), half_m: (radius_m, radius_m), sin: 0.0, cos: 1.0 }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances_and_outlines_follow_each_shape() {
        let tree = Obstacle::Cylinder { base_ne_m: [10.0, 5.0], radius_m: 1.0, height_m: 8.0 };
        assert!((horizontal_distance_m(&tree, (10.0, 0.0)) - 4.0).abs() < 1e-12);
        assert_eq!(heights_m(&tree), (0.0, 8.0));
        let shed = Obstacle::Box { center_ned_m: [0.0, 0.0, -3.0], size_m: [4.0, 2.0, 2.0], yaw_deg: 90.0 };
        // Turned 90°: its 4 m side lies along east.
        assert!((horizontal_distance_m(&shed, (0.0, 3.0)) - 1.0).abs() < 1e-9);
        assert!((horizontal_distance_m(&shed, (2.0, 0.0)) - 1.0).abs() < 1e-9);
        assert_eq!(heights_m(&shed), (2.0, 4.0));
        let corners = outline_ne_m(&shed);
        assert!(corners.iter().all(|(n, e)| (n.abs() - 1.0).abs() < 1e-9 && (e.abs() - 2.0).abs() < 1e-9));
        let wall = Obstacle::Wall {
            from_ne_m: [20.0, -10.0],
            to_ne_m: [20.0, 10.0],
            height_m: 5.0,
            thickness_m: 0.2,
            textured: false,
        };
        assert!((horizontal_distance_m(&wall, (15.0, 3.0)) - 4.9).abs() < 1e-9);
        assert!((horizontal_distance_m(&wall, (20.0, 13.0)) - 3.0).abs() < 1e-9);
        assert_eq!(kind(&wall), Kind::PlainWall);
    }
}
