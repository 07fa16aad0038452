//! World obstacles and the distance from a point to their surfaces.
//!
//! Boxes, vertical cylinders ("trees") and walls, each standing on or above the flat ground.
//! Distances are exact signed distances (negative inside), which gives both the collision test
//! (distance below the vehicle's collision radius) and the clearance the flight report scores.
//! Rays are intersected exactly (slabs and a quadratic, in double precision) for the
//! rangefinders, which need the first surface along a beam however closely it grazes another.

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
    /// Distance along the ray from `origin_ned_m` in the unit direction `dir_ned` to where it
    /// first meets the obstacle (m): 0 when the origin is inside or on it, `None` when the ray
    /// misses it or leaves it behind.
    fn ray_hit_m(&self, origin_ned_m: &Vector3<f64>, dir_ned: &Vector3<f64>) -> Option<f64>;
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
                let (center, half, yaw_deg) = wall_box(from_ne_m, to_ne_m, *height_m, *thickness_m);
                box_distance(p_ned_m, &center, &half, yaw_deg)
            }
        }
    }

    fn ray_hit_m(&self, origin_ned_m: &Vector3<f64>, dir_ned: &Vector3<f64>) -> Option<f64> {
        match self {
            Obstacle::Box { center_ned_m, size_m, yaw_deg } => box_ray_hit(
                origin_ned_m,
                dir_ned,
                &Vector3::from(*center_ned_m),
                &(Vector3::from(*size_m) / 2.0),
                *yaw_deg,
            ),
            Obstacle::Cylinder { base_ne_m, radius_m, height_m } => {
                let radial =
                    disc_span(&(origin_ned_m.xy() - Vector2::from(*base_ne_m)), &dir_ned.xy(), *radius_m)?;
                let vertical = slab_span(origin_ned_m.z, dir_ned.z, -height_m, 0.0)?;
                entry([radial, vertical])
            }
            Obstacle::Wall { from_ne_m, to_ne_m, height_m, thickness_m, .. } => {
                let (center, half, yaw_deg) = wall_box(from_ne_m, to_ne_m, *height_m, *thickness_m);
                box_ray_hit(origin_ned_m, dir_ned, &center, &half, yaw_deg)
            }
        }
    }
}

/// A wall as the box it is: centre (NED, m), half-extents along, across and up (m), and the yaw
/// of its run from `from` to `to` (degrees).
fn wall_box(
    from_ne_m: &[f64; 2],
    to_ne_m: &[f64; 2],
    height_m: f64,
    thickness_m: f64,
) -> (Vector3<f64>, Vector3<f64>, f64) {
    let (from, to) = (Vector2::from(*from_ne_m), Vector2::from(*to_ne_m));
    let along = to - from;
    let mid = (from + to) / 2.0;
    let center = Vector3::new(mid.x, mid.y, -height_m / 2.0);
    let half = Vector3::new(along.norm() / 2.0, thickness_m / 2.0, height_m / 2.0);
    (center, half, along.y.atan2(along.x).to_degrees())
}

/// `d` (NED) in the axes of a box yawed by `yaw_deg`: the one rotation both the distance and
/// the ray use.
fn box_local(d: &Vector3<f64>, yaw_deg: f64) -> Vector3<f64> {
    let (sin, cos) = yaw_deg.to_radians().sin_cos();
    Vector3::new(cos * d.x + sin * d.y, -sin * d.x + cos * d.y, d.z)
}

/// Signed distance to a box of half-extents `half` centred at `center`, yawed by `yaw_deg`.
fn box_distance(p: &Vector3<f64>, center: &Vector3<f64>, half: &Vector3<f64>, yaw_deg: f64) -> f64 {
    let q = box_local(&(p - center), yaw_deg).abs() - half;
    q.map(|c| c.max(0.0)).norm() + q.max().min(0.0)
}

/// Where the ray enters a box of half-extents `half` centred at `center`, yawed by `yaw_deg`
/// (slab method in the box's own axes).
fn box_ray_hit(
    origin: &Vector3<f64>,
    dir: &Vector3<f64>,
    center: &Vector3<f64>,
    half: &Vector3<f64>,
    yaw_deg: f64,
) -> Option<f64> {
    let (o, d) = (box_local(&(origin - center), yaw_deg), box_local(dir, yaw_deg));
    entry([
        slab_span(o.x, d.x, -half.x, half.x)?,
        slab_span(o.y, d.y, -half.y, half.y)?,
        slab_span(o.z, d.z, -half.z, half.z)?,
    ])
}

/// The ray parameters `t` at which `o + t·d` lies within `lo..=hi` along one axis, or `None`
/// when a ray parallel to the slab lies outside it.
fn slab_span(o: f64, d: f64, lo: f64, hi: f64) -> Option<(f64, f64)> {
    if d == 0.0 {
        return (lo..=hi).contains(&o).then_some((f64::NEG_INFINITY, f64::INFINITY));
    }
    let (a, b) = ((lo - o) / d, (hi - o) / d);
    Some((a.min(b), a.max(b)))
}

/// The ray parameters at which the horizontal track `o + t·d` (relative to a vertical axis) lies
/// within `radius` of the axis, or `None` when it never does.
fn disc_span(o: &Vector2<f64>, d: &Vector2<f64>, radius: f64) -> Option<(f64, f64)> {
    let c = o.norm_squared() - radius * radius;
    let a = d.norm_squared();
    // A beam within a nanoradian of vertical keeps its distance from the axis over any range
    // a rangefinder reaches; dividing by `a` would only amplify rounding.
    if a < 1e-18 {
        return (c <= 0.0).then_some((f64::NEG_INFINITY, f64::INFINITY));
    }
    let b = o.dot(d);
    let discriminant = b * b - a * c;
    if discriminant < 0.0 {
        return None;
    }
    let root = discriminant.sqrt();
    Some(((-b - root) / a, (-b + root) / a))
}

/// Where a ray enters the intersection of `spans` (0 from inside), or `None` when the
/// intersection is empty or behind the origin.
fn entry<const N: usize>(spans: [(f64, f64); N]) -> Option<f64> {
    let enter = spans.iter().map(|s| s.0).fold(f64::NEG_INFINITY, f64::max).max(0.0);
    let leave = spans.iter().map(|s| s.1).fold(f64::INFINITY, f64::min);
    (enter <= leave).then_some(enter)
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
