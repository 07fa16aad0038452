//! The world as the renderer sees it: flat ground at down = 0 plus the obstacles, in single
//! precision, with ray intersection written out per shape.
//!
//! Rays are `origin + t·dir` in NED (m). `dir` need not be unit length: the renderer scales it
//! so `t` is the depth along the camera's optical axis.

use nalgebra::Vector3;

use crate::obstacles::Obstacle;

/// Hits nearer than this along a ray are ignored (ray parameter units), so a camera touching a
/// surface does not see its own contact point.
const MIN_T: f32 = 1e-4;

/// The ground, boxes, cylinders and walls of a world.
#[derive(Clone, Debug)]
pub struct Scene {
    shapes: Vec<Shape>,
}

/// A surface point a ray hit, ready for shading.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Surface {
    /// Outward unit normal (NED).
    pub(crate) normal: Vector3<f32>,
    /// Coordinates across the surface (m), continuous within a face, for the texture.
    pub(crate) u: f32,
    pub(crate) v: f32,
    /// Which surface: 0 is the ground, obstacle `i` is `i + 1`.
    pub(crate) material: u32,
    /// Whether the surface carries texture.
    pub(crate) textured: bool,
}

/// One obstacle in renderer form.
#[derive(Clone, Debug)]
pub(crate) enum Shape {
    /// A box yawed about down: boxes and walls.
    Cuboid { center: Vector3<f32>, half: Vector3<f32>, cos: f32, sin: f32, textured: bool },
    /// A vertical cylinder from the ground (down = 0) up to down = −height.
    Cylinder { center_ne: [f32; 2], radius: f32, height: f32 },
}

impl Scene {
    /// The renderer's copy of `obstacles` (validated ones, as a loaded [`World`](crate::World) holds).
    pub fn new(obstacles: &[Obstacle]) -> Scene {
        Scene { shapes: obstacles.iter().map(Shape::new).collect() }
    }

    pub(crate) fn shapes(&self) -> &[Shape] {
        &self.shapes
    }

    /// The ground's ray parameter, if the ray goes down onto it from above.
    pub(crate) fn ground_hit(origin: &Vector3<f32>, dir: &Vector3<f32>) -> Option<f32> {
        (origin.z < 0.0 && dir.z > 0.0).then(|| -origin.z / dir.z)
    }

    /// The ground as a surface, at `point` (NED, m).
    pub(crate) fn ground_surface(point: &Vector3<f32>) -> Surface {
        Surface { normal: Vector3::new(0.0, 0.0, -1.0), u: point.x, v: point.y, material: 0, textured: true }
    }
}

impl Shape {
    fn new(obstacle: &Obstacle) -> Shape {
        match obstacle {
            Obstacle::Box { center_ned_m, size_m, yaw_deg } => {
                let (sin, cos) = yaw_deg.to_radians().sin_cos();
                Shape::Cuboid {
                    center: Vector3::from(*center_ned_m).cast(),
                    half: (Vector3::from(*size_m) / 2.0).cast(),
                    cos: cos as f32,
                    sin: sin as f32,
                    textured: true,
                }
            }
            Obstacle::Cylinder { base_ne_m, radius_m, height_m } => Shape::Cylinder {
                center_ne: [base_ne_m[0] as f32, base_ne_m[1] as f32],
                radius: *radius_m as f32,
                height: *height_m as f32,
            },
            Obstacle::Wall { from_ne_m, to_ne_m, height_m, thickness_m, textured } => {
                let along = [to_ne_m[0] - from_ne_m[0], to_ne_m[1] - from_ne_m[1]];
                let length = along[0].hypot(along[1]);
                Shape::Cuboid {
                    center: Vector3::new(
                        (from_ne_m[0] + to_ne_m[0]) / 2.0,
                        (from_ne_m[1] + to_ne_m[1]) / 2.0,
                        -height_m / 2.0,
                    )
                    .cast(),
                    half: Vector3::new(length / 2.0, thickness_m / 2.0, height_m / 2.0).cast(),
                    cos: (along[0] / length) as f32,
                    sin: (along[1] / length) as f32,
                    textured: *textured,
                }
            }
        }
    }

    /// The corners of a box enclosing the shape (NED, m), for culling.
    pub(crate) fn bounding_corners(&self) -> [Vector3<f32>; 8] {
        let (center, half, cos, sin) = match *self {
            Shape::Cuboid { center, half, cos, sin, .. } => (center, half, cos, sin),
            Shape::Cylinder { center_ne, radius, height } => (
                Vector3::new(center_ne[0], center_ne[1], -height / 2.0),
                Vector3::new(radius, radius, height / 2.0),
                1.0,
                0.0,
            ),
        };
        std::array::from_fn(|i| {
            let sign = |bit: usize| if i & bit == 0 { -1.0 } else { 1.0 };
            let local = Vector3::new(sign(1) * half.x, sign(2) * half.y, sign(4) * half.z);
            center + Vector3::new(cos * local.x - sin * local.y, sin * local.x + cos * local.y, local.z)
        })
    }

    /// The ray parameter where the ray enters the shape and which face it enters by, or `None`
    /// for a miss (or a ray starting inside).
    #[cfg(any(test, feature = "render-reference"))]
    pub(crate) fn hit(&self, origin: &Vector3<f32>, dir: &Vector3<f32>) -> Option<(f32, u8)> {
        match *self {
            Shape::Cuboid { center, half, cos, sin, .. } => {
                let (o, d) = cuboid_local(origin - center, *dir, cos, sin);
                slab_hit(&o, &d, &half)
            }
            Shape::Cylinder { center_ne, radius, height } => {
                cylinder_hit(origin, dir, center_ne, radius, height)
            }
        }
    }

    /// The surface at `t` along the ray, on the face [`Shape::hit`] returned.
    pub(crate) fn surface(
        &self,
        material: u32,
        origin: &Vector3<f32>,
        dir: &Vector3<f32>,
        t: f32,
        face: u8,
    ) -> Surface {
        match *self {
            Shape::Cuboid { center, cos, sin, textured, .. } => {
                let (o, d) = cuboid_local(origin - center, *dir, cos, sin);
                let p = o + t * d;
                let axis = usize::from(face / 2);
                let sign = if face.is_multiple_of(2) { -1.0 } else { 1.0 };
                let mut local_normal = Vector3::zeros();
                local_normal[axis] = sign;
                let normal = Vector3::new(
                    cos * local_normal.x - sin * local_normal.y,
                    sin * local_normal.x + cos * local_normal.y,
                    local_normal.z,
                );
                let (u, v) = match axis {
                    0 => (p.y, p.z),
                    1 => (p.x, p.z),
                    _ => (p.x, p.y),
                };
                Surface { normal, u, v, material, textured }
            }
            Shape::Cylinder { center_ne, radius, .. } => {
                let p = origin + t * dir;
                let (dx, dy) = (p.x - center_ne[0], p.y - center_ne[1]);
                if face == 0 {
                    let normal = Vector3::new(dx / radius, dy / radius, 0.0);
                    Surface { normal, u: dy.atan2(dx) * radius, v: p.z, material, textured: true }
                } else {
                    Surface { normal: Vector3::new(0.0, 0.0, -1.0), u: p.x, v: p.y, material, textured: true }
                }
            }
        }
    }
}

/// A shape as seen from one ray origin, for the fast caster: [`Shape::hit`] with everything
/// that depends only on the shape and the origin done once, and the rest written without
/// branches so a loop over the rays of a row vectorises. The same operations on the same
/// numbers, so the same hits bit for bit (a test holds it to [`Shape::hit`]).
#[derive(Clone, Copy, Debug)]
pub(crate) enum ShapeFrom {
    Cuboid(CuboidFrom),
    Cylinder(CylinderFrom),
}

/// A cuboid seen from an origin: the origin in the cuboid's own axes.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CuboidFrom {
    origin_local: Vector3<f32>,
    half: Vector3<f32>,
    cos: f32,
    sin: f32,
}

/// A cylinder seen from an origin: the origin relative to the axis, and
/// `|origin − axis|² − radius²` across it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CylinderFrom {
    origin: Vector3<f32>,
    ox: f32,
    oy: f32,
    c: f32,
    radius: f32,
    height: f32,
}

/// The hit of a ray along `dir` from a prepared origin: the ray parameter where it enters the
/// shape and the face it enters by, as [`Shape::hit`] gives them, with an infinite parameter
/// for a miss.
pub(crate) trait RayHit {
    fn hit(&self, dir: &Vector3<f32>) -> (f32, u8);
}

impl Shape {
    /// The shape as seen from `origin` (NED, m).
    pub(crate) fn seen_from(&self, origin: &Vector3<f32>) -> ShapeFrom {
        match *self {
            Shape::Cuboid { center, half, cos, sin, .. } => {
                let (origin_local, _) = cuboid_local(origin - center, Vector3::zeros(), cos, sin);
                ShapeFrom::Cuboid(CuboidFrom { origin_local, half, cos, sin })
            }
            Shape::Cylinder { center_ne, radius, height } => {
                let (ox, oy) = (origin.x - center_ne[0], origin.y - center_ne[1]);
                let c = ox * ox + oy * oy - radius * radius;
                ShapeFrom::Cylinder(CylinderFrom { origin: *origin, ox, oy, c, radius, height })
            }
        }
    }
}

impl RayHit for ShapeFrom {
    #[inline(always)]
    fn hit(&self, dir: &Vector3<f32>) -> (f32, u8) {
        match self {
            ShapeFrom::Cuboid(cuboid) => cuboid.hit(dir),
            ShapeFrom::Cylinder(cylinder) => cylinder.hit(dir),
        }
    }
}

impl RayHit for CuboidFrom {
    #[inline(always)]
    fn hit(&self, dir: &Vector3<f32>) -> (f32, u8) {
        let (_, d) = cuboid_local(Vector3::zeros(), *dir, self.cos, self.sin);
        slab_hit_lane(&self.origin_local, &d, &self.half)
    }
}

impl RayHit for CylinderFrom {
    /// [`cylinder_hit`] with its conditions evaluated in full and combined.
    #[inline(always)]
    fn hit(&self, dir: &Vector3<f32>) -> (f32, u8) {
        let CylinderFrom { origin, ox, oy, c, radius, height } = *self;
        let a = dir.x * dir.x + dir.y * dir.y;
        let b = ox * dir.x + oy * dir.y;
        let disc = b * b - a * c;
        let t_side = (-b - disc.sqrt()) / a;
        let z = origin.z + t_side * dir.z;
        let side = (a > 0.0) & (disc >= 0.0) & (t_side > MIN_T) & (-height <= z) & (z <= 0.0);
        let t_top = (-height - origin.z) / dir.z;
        let (x, y) = (ox + t_top * dir.x, oy + t_top * dir.y);
        let top =
            (dir.z != 0.0) & (t_top > MIN_T) & (origin.z < -height) & (x * x + y * y <= radius * radius);
        if side {
            (t_side, 0)
        } else if top {
            (t_top, 1)
        } else {
            (f32::INFINITY, 0)
        }
    }
}

/// [`slab_hit`] without branches: an axis the ray runs parallel to leaves the interval alone
/// and only checks the origin is within its slab; an infinite parameter for a miss.
#[inline(always)]
fn slab_hit_lane(o: &Vector3<f32>, d: &Vector3<f32>, half: &Vector3<f32>) -> (f32, u8) {
    let (mut near, mut far, mut face, mut within) = (f32::NEG_INFINITY, f32::INFINITY, 0u8, true);
    for axis in 0..3 {
        let parallel = d[axis] == 0.0;
        within &= !(parallel & (o[axis].abs() > half[axis]));
        let inv = 1.0 / d[axis];
        let (a, b) = ((-half[axis] - o[axis]) * inv, (half[axis] - o[axis]) * inv);
        let (enter, exit) = if a < b { (a, b) } else { (b, a) };
        let nearer = !parallel & (enter > near);
        face = if nearer { 2 * axis as u8 + u8::from(d[axis] < 0.0) } else { face };
        near = if nearer { enter } else { near };
        far = if parallel { far } else { far.min(exit) };
    }
    if within & (near <= far) & (near > MIN_T) { (near, face) } else { (f32::INFINITY, 0) }
}

/// A ray relative to a cuboid's centre, turned into its own axes (undoing the yaw).
fn cuboid_local(o: Vector3<f32>, d: Vector3<f32>, cos: f32, sin: f32) -> (Vector3<f32>, Vector3<f32>) {
    let turn = |v: Vector3<f32>| Vector3::new(cos * v.x + sin * v.y, -sin * v.x + cos * v.y, v.z);
    (turn(o), turn(d))
}

/// Slab test against the axis-aligned box `[-half, half]`; the face is `2·axis` when entering
/// through the negative side, `2·axis + 1` through the positive side.
#[cfg(any(test, feature = "render-reference"))]
fn slab_hit(o: &Vector3<f32>, d: &Vector3<f32>, half: &Vector3<f32>) -> Option<(f32, u8)> {
    let (mut near, mut far, mut face) = (f32::NEG_INFINITY, f32::INFINITY, 0u8);
    for axis in 0..3 {
        if d[axis] == 0.0 {
            if o[axis].abs() > half[axis] {
                return None;
            }
            continue;
        }
        let inv = 1.0 / d[axis];
        let (a, b) = ((-half[axis] - o[axis]) * inv, (half[axis] - o[axis]) * inv);
        let (enter, exit) = if a < b { (a, b) } else { (b, a) };
        if enter > near {
            near = enter;
            face = 2 * axis as u8 + u8::from(d[axis] < 0.0);
        }
        far = far.min(exit);
    }
    (near <= far && near > MIN_T).then_some((near, face))
}

/// A vertical cylinder from down = 0 to down = −height: face 0 is the side, 1 the top.
#[cfg(any(test, feature = "render-reference"))]
fn cylinder_hit(
    origin: &Vector3<f32>,
    dir: &Vector3<f32>,
    center_ne: [f32; 2],
    radius: f32,
    height: f32,
) -> Option<(f32, u8)> {
    let (ox, oy) = (origin.x - center_ne[0], origin.y - center_ne[1]);
    let a = dir.x * dir.x + dir.y * dir.y;
    let b = ox * dir.x + oy * dir.y;
    let c = ox * ox + oy * oy - radius * radius;
    if a > 0.0 {
        let disc = b * b - a * c;
        if disc >= 0.0 {
            let t = (-b - disc.sqrt()) / a;
            let z = origin.z + t * dir.z;
            if t > MIN_T && (-height..=0.0).contains(&z) {
                return Some((t, 0));
            }
        }
    }
    if dir.z != 0.0 {
        let t = (-height - origin.z) / dir.z;
        let (x, y) = (ox + t * dir.x, oy + t * dir.y);
        if t > MIN_T && origin.z < -height && x * x + y * y <= radius * radius {
            return Some((t, 1));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ray(o: [f32; 3], d: [f32; 3]) -> (Vector3<f32>, Vector3<f32>) {
        (Vector3::from(o), Vector3::from(d))
    }

    #[test]
    fn boxes_cylinders_and_walls_are_entered_where_expected() {
        let cube = Shape::new(&Obstacle::Box {
            center_ned_m: [10.0, 0.0, -1.0],
            size_m: [2.0, 2.0, 2.0],
            yaw_deg: 0.0,
        });
        let (o, d) = ray([0.0, 0.0, -1.0], [1.0, 0.0, 0.0]);
        let (t, face) = cube.hit(&o, &d).unwrap();
        assert!((t - 9.0).abs() < 1e-5);
        assert_eq!(cube.surface(1, &o, &d, t, face).normal, Vector3::new(-1.0, 0.0, 0.0));
        assert!(cube.hit(&o, &-d).is_none());

        let turned = Shape::new(&Obstacle::Box {
            center_ned_m: [10.0, 0.0, -1.0],
            size_m: [2.0, 2.0, 2.0],
            yaw_deg: 45.0,
        });
        let (t, _) = turned.hit(&o, &d).unwrap();
        assert!((t - (10.0 - 2f32.sqrt())).abs() < 1e-5);

        let tree = Shape::new(&Obstacle::Cylinder { base_ne_m: [5.0, 0.0], radius_m: 0.5, height_m: 4.0 });
        assert!((tree.hit(&o, &d).unwrap().0 - 4.5).abs() < 1e-5);
        let (above, down) = ray([5.0, 0.0, -10.0], [0.0, 0.0, 1.0]);
        assert_eq!(tree.hit(&above, &down), Some((6.0, 1)));
        let (over, _) = ray([0.0, 0.0, -5.0], [1.0, 0.0, 0.0]);
        assert!(tree.hit(&over, &d).is_none());

        let wall = Shape::new(&Obstacle::Wall {
            from_ne_m: [20.0, -10.0],
            to_ne_m: [20.0, 10.0],
            height_m: 5.0,
            thickness_m: 0.2,
            textured: false,
        });
        let (t, face) = wall.hit(&o, &d).unwrap();
        assert!((t - 19.9).abs() < 1e-4);
        let s = wall.surface(3, &o, &d, t, face);
        assert!(!s.textured);
        assert!((s.normal - Vector3::new(-1.0, 0.0, 0.0)).norm() < 1e-6);
    }

    fn any_shape() -> impl proptest::strategy::Strategy<Value = Shape> {
        use proptest::prelude::*;
        prop_oneof![
            (
                [-30.0f64..30.0, -30.0..30.0, -10.0..0.0],
                [0.1f64..10.0, 0.1..10.0, 0.1..10.0],
                -180.0f64..180.0
            )
                .prop_map(|(center_ned_m, size_m, yaw_deg)| Shape::new(&Obstacle::Box {
                    center_ned_m,
                    size_m,
                    yaw_deg
                })),
            ([-30.0f64..30.0, -30.0..30.0], 0.1f64..3.0, 0.5f64..20.0).prop_map(
                |(base_ne_m, radius_m, height_m)| Shape::new(&Obstacle::Cylinder {
                    base_ne_m,
                    radius_m,
                    height_m
                })
            ),
        ]
    }

    /// A ray direction: mostly anywhere, sometimes along an axis or in a plane of two.
    fn any_dir() -> impl proptest::strategy::Strategy<Value = [f32; 3]> {
        use proptest::prelude::*;
        let component = prop_oneof![4 => -2.0f32..2.0, 1 => Just(0.0f32)];
        [component.clone(), component.clone(), component]
    }

    proptest::proptest! {
        /// The branch-free hit from a prepared origin is the shape's own, bit for bit, over
        /// random shapes, origins (outside and inside) and rays, axis-parallel ones included,
        /// most of them aimed at the shape.
        #[test]
        fn a_shape_seen_from_an_origin_is_hit_as_the_shape_is(
            shape in any_shape(),
            origin in [-40.0f32..40.0, -40.0..40.0, -20.0..1.0],
            dirs in proptest::collection::vec(any_dir(), 1..40),
        ) {
            // A third of the rays from `origin` anywhere, a third from it aimed near the shape's
            // centre, and a third from above the shape straight down near its centre, so that
            // sides and tops are hit too.
            let corners = shape.bounding_corners();
            let centre = corners.iter().sum::<Vector3<f32>>() / 8.0;
            for (i, offset) in dirs.into_iter().enumerate() {
                let offset = Vector3::from(offset);
                let (origin, dir) = match i % 3 {
                    0 => (Vector3::from(origin), offset),
                    1 => (Vector3::from(origin), centre + offset - Vector3::from(origin)),
                    _ => (centre + Vector3::new(offset.x / 4.0, offset.y / 4.0, -30.0), Vector3::new(offset.z / 10.0, offset.y / 10.0, 1.0)),
                };
                let seen = shape.seen_from(&origin);
                let fast = seen.hit(&dir);
                match shape.hit(&origin, &dir) {
                    Some((t, face)) => proptest::prop_assert_eq!((fast.0.to_bits(), fast.1), (t.to_bits(), face)),
                    None => proptest::prop_assert_eq!(fast.0, f32::INFINITY),
                }
            }
        }
    }

    #[test]
    fn the_ground_is_below_and_never_above() {
        let (o, d) = ray([0.0, 0.0, -2.0], [1.0, 0.0, 0.5]);
        assert_eq!(Scene::ground_hit(&o, &d), Some(4.0));
        assert_eq!(Scene::ground_hit(&o, &-d), None);
    }
}
