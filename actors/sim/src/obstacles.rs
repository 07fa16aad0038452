//! World obstacles and the distance from a point to their surfaces.
//!
//! Boxes, vertical cylinders ("trees") and walls, each standing on or above the flat ground.
//! Distances are exact signed distances (negative inside), which gives both the collision test
//! (distance below the vehicle's collision radius) and the clearance the flight report scores.

use nalgebra::{Vector2, Vector3};

use crate::error::{InvalidParam, finite, positive};

pub use kestrel_proto::messages::Obstacle;

/// What the simulator needs of an obstacle beyond its shape: a check of a world file's values
/// and the distance to its surface.
pub trait ObstacleGeometry {
    /// Checks every value, naming the first bad one.
    fn validate(&self) -> Result<(), InvalidParam>;
    /// Signed distance from `p_ned_m` to the obstacle's surface (m), negative inside.
    fn signed_distance_m(&self, p_ned_m: &Vector3<f64>) -> f64;
}

impl ObstacleGeometry for Obstacle {
    fn validate(&self) -> Result<(), InvalidParam> {
        match self {
            Obstacle::Box { center_ned_m, size_m, yaw_deg } => {
                finite("center_ned_m", center_ned_m)?;
                finite("yaw_deg", &[*yaw_deg])?;
                for (i, &s) in size_m.iter().enumerate() {
                    positive(&format!("size_m[{i}]"), s)?;
                }
                Ok(())
            }
            Obstacle::Cylinder { base_ne_m, radius_m, height_m } => {
                finite("base_ne_m", base_ne_m)?;
                positive("radius_m", *radius_m)?;
                positive("height_m", *height_m)
            }
            Obstacle::Wall { from_ne_m, to_ne_m, height_m, thickness_m, .. } => {
                finite("from_ne_m", from_ne_m)?;
                finite("to_ne_m", to_ne_m)?;
                positive("height_m", *height_m)?;
                positive("thickness_m", *thickness_m)?;
                if Vector2::from(*from_ne_m) == Vector2::from(*to_ne_m) {
                    return Err(InvalidParam::new("to_ne_m", "must differ from from_ne_m"));
                }
                Ok(())
            }
        }
    }

    fn signed_distance_m(&self, p_ned_m: &Vector3<f64>) -> f64 {
        match self {
            Obstacle::Box { center_ned_m, size_m, yaw_deg } => box_distance(
                p_ned_m,
                &Vector3::from(*center_ned_m),
                &(Vector3::from(*size_m) / 2.0),
                *yaw_deg,
            ),
            Obstacle::Cylinder { base_ne_m, radius_m, height_m } => {
                let radial = (p_ned_m.xy() - Vector2::from(*base_ne_m)).norm() - radius_m;
                let vertical = (p_ned_m.z + height_m / 2.0).abs() - height_m / 2.0;
                let outside = Vector2::new(radial.max(0.0), vertical.max(0.0)).norm();
                outside + radial.max(vertical).min(0.0)
            }
            Obstacle::Wall { from_ne_m, to_ne_m, height_m, thickness_m, .. } => {
                let (from, to) = (Vector2::from(*from_ne_m), Vector2::from(*to_ne_m));
                let along = to - from;
                let mid = (from + to) / 2.0;
                let center = Vector3::new(mid.x, mid.y, -height_m / 2.0);
                let half = Vector3::new(along.norm() / 2.0, thickness_m / 2.0, height_m / 2.0);
                box_distance(p_ned_m, &center, &half, along.y.atan2(along.x).to_degrees())
            }
        }
    }
}

/// Signed distance to a box of half-extents `half` centred at `center`, yawed by `yaw_deg`.
fn box_distance(p: &Vector3<f64>, center: &Vector3<f64>, half: &Vector3<f64>, yaw_deg: f64) -> f64 {
    let d = p - center;
    let (sin, cos) = yaw_deg.to_radians().sin_cos();
    let local = Vector3::new(cos * d.x + sin * d.y, -sin * d.x + cos * d.y, d.z);
    let q = local.abs() - half;
    q.map(|c| c.max(0.0)).norm() + q.max().min(0.0)
}

/// Collision bookkeeping against a world's obstacles.
#[derive(Clone, Debug, Default)]
pub(crate) struct Collisions {
    /// Collisions so far (each entry into contact counts once).
    pub(crate) count: u32,
    /// Distance from the centre to the nearest obstacle surface (m), ≥ 0; infinite when empty.
    pub(crate) clearance_m: f64,
    touching: bool,
}

impl Collisions {
    pub(crate) fn new() -> Collisions {
        Collisions { count: 0, clearance_m: f64::INFINITY, touching: false }
    }

    /// Updates clearance and counts a new collision when the sphere of `radius_m` around
    /// `p_ned_m` starts touching an obstacle.
    pub(crate) fn update(&mut self, obstacles: &[Obstacle], p_ned_m: &Vector3<f64>, radius_m: f64) {
        let nearest = obstacles.iter().map(|o| o.signed_distance_m(p_ned_m)).fold(f64::INFINITY, f64::min);
        self.clearance_m = nearest.max(0.0);
        let touching = nearest < radius_m;
        if touching && !self.touching {
            self.count += 1;
        }
        self.touching = touching;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances_to_each_shape() {
        let cube = Obstacle::Box { center_ned_m: [10.0, 0.0, -1.0], size_m: [2.0, 2.0, 2.0], yaw_deg: 0.0 };
        assert!((cube.signed_distance_m(&Vector3::new(5.0, 0.0, -1.0)) - 4.0).abs() < 1e-12);
        assert!((cube.signed_distance_m(&Vector3::new(10.0, 0.0, -1.0)) + 1.0).abs() < 1e-12);
        let turned = Obstacle::Box { center_ned_m: [0.0, 0.0, -1.0], size_m: [4.0, 2.0, 2.0], yaw_deg: 90.0 };
        assert!((turned.signed_distance_m(&Vector3::new(0.0, 3.0, -1.0)) - 1.0).abs() < 1e-9);
        let tree = Obstacle::Cylinder { base_ne_m: [0.0, 5.0], radius_m: 0.5, height_m: 6.0 };
        assert!((tree.signed_distance_m(&Vector3::new(0.0, 0.0, -3.0)) - 4.5).abs() < 1e-12);
        assert!((tree.signed_distance_m(&Vector3::new(0.0, 5.0, -10.0)) - 4.0).abs() < 1e-12);
        let wall = Obstacle::Wall {
            from_ne_m: [20.0, -10.0],
            to_ne_m: [20.0, 10.0],
            height_m: 5.0,
            thickness_m: 0.2,
            textured: false,
        };
        assert!((wall.signed_distance_m(&Vector3::new(15.0, 3.0, -2.0)) - 4.9).abs() < 1e-9);
        assert!((wall.signed_distance_m(&Vector3::new(20.0, 13.0, -2.0)) - 3.0).abs() < 1e-9);
    }
}
