//! The ray caster behind [`StereoCamera::render_moving`]: every ray of a camera starts at the
//! same point, so the acceleration structure is in screen space. Each obstacle is projected
//! once per view to the rectangle of pixels it can cover, and the rectangles are binned into
//! bands of [`BAND_ROWS`] rows; a row then tests only the obstacles of its band whose
//! rectangle spans it, and only over the columns it spans.
//!
//! A row is cast in passes over arrays, one column per entry ([`Columns`], borrowed as slices
//! of the row's width so the loops keep their pointers in registers and check no index), each
//! a loop without branches that the compiler vectorises: the ray and the ground (or sky) of
//! every column; each obstacle over its columns, prepared once per view for the origin
//! ([`ShapeFrom`]); the surfaces, the light and the texel footprints; the texture of the row
//! ([`Texture::sample_batch`](crate::camera::texture), the part that costs most); the radiance.
//! Only the obstacles' surfaces (an arc tangent per cylinder pixel) are computed a column at a
//! time. On x86-64 hosts with AVX2 the same code is compiled a second time for AVX2 (found at
//! run time), which gives the loops 8 lanes; the arithmetic is IEEE the same either way, so the
//! images are too. The result is bit for bit the per-pixel reference renderer's
//! (`camera/reference.rs`, the test and bench baseline).

use std::ops::Range;

use nalgebra::Vector3;

use crate::camera::render::{
    PLAIN_ALBEDO, PixelRect, SKY, StereoCamera, View, light, radiance, texel_footprint_m, textured_albedo,
};
use crate::camera::scene::{RayHit, Scene, ShapeFrom, Surface};
use crate::camera::texture::Texels;

/// Rows per band of the screen-space bins: small enough that a band holds few obstacles that
/// miss a row, large enough that binning costs little against a band's pixels.
const BAND_ROWS: usize = 16;

/// What a column's ray hit first, as [`Columns::hit`] holds it: an obstacle's index in the
/// scene, or one of these two (a scene has fewer obstacles than either).
const HIT_SKY: u32 = u32::MAX;
const HIT_GROUND: u32 = u32::MAX - 1;

/// Working memory of the caster, kept between rows, views and frames so casting allocates
/// nothing once warm.
#[derive(Clone, Debug, Default)]
pub(crate) struct RowBuffers {
    /// The obstacles whose projected rectangle meets each band of rows, in scene order.
    bands: Vec<Vec<(u32, PixelRect)>>,
    /// The row being cast, one entry per column.
    columns: Columns<Vec<f32>, Vec<u32>, Vec<u8>, Vec<bool>>,
}

/// Per column of a row, in separate arrays (structure of arrays) so that each pass over a row
/// is a loop the compiler vectorises: owned by [`RowBuffers`], and borrowed as slices of the
/// row's width while casting, so the loops keep their pointers in registers and need no
/// bounds checks.
#[derive(Clone, Debug, Default)]
struct Columns<F, U, B, Flag> {
    /// The ray (NED), scaled so its parameter is the depth.
    dir_x: F,
    dir_y: F,
    dir_z: F,
    /// The depth of the nearest hit (m, infinite for sky), what it hit ([`HIT_SKY`],
    /// [`HIT_GROUND`] or an obstacle's index) and through which face
    /// ([`Shape::hit`](crate::camera::scene)).
    depth_m: F,
    hit: U,
    face: B,
    /// The surface hit: outward unit normal (NED), texture coordinates (m), material, whether
    /// textured; meaningless for sky.
    normal_x: F,
    normal_y: F,
    normal_z: F,
    u: F,
    v: F,
    material: U,
    textured: Flag,
    /// The light on that surface, the texel footprint there (m) and the texture's value.
    light: F,
    footprint_m: F,
    texture: F,
    /// The radiance (grey levels at unit gain).
    radiance: F,
}

/// A row's [`Columns`] while it is cast.
type Row<'a> = Columns<&'a mut [f32], &'a mut [u32], &'a mut [u8], &'a mut [bool]>;

impl RowBuffers {
    /// Bins the obstacles of `scene` that `camera` can see from `view` into bands of rows.
    fn bin(&mut self, camera: &StereoCamera, scene: &Scene, view: &View) {
        let bands = camera.row_rays.len().div_ceil(BAND_ROWS);
        self.bands.resize_with(bands, Vec::new);
        for band in &mut self.bands {
            band.clear();
        }
        for (index, shape) in scene.shapes().iter().enumerate() {
            if let Some(rect) = camera.projection(shape, view) {
                for band in &mut self.bands[rect.rows.0 / BAND_ROWS..=rect.rows.1 / BAND_ROWS] {
                    band.push((index as u32, rect));
                }
            }
        }
    }

    /// The bands and a row of `width` columns. Inlined, so that the passes over the row know
    /// each slice is `width` long and check no index.
    #[inline(always)]
    fn row(&mut self, width: usize) -> (&[Vec<(u32, PixelRect)>], Row<'_>) {
        let c = &mut self.columns;
        for array in [
            &mut c.dir_x,
            &mut c.dir_y,
            &mut c.dir_z,
            &mut c.depth_m,
            &mut c.normal_x,
            &mut c.normal_y,
            &mut c.normal_z,
            &mut c.u,
            &mut c.v,
            &mut c.light,
            &mut c.footprint_m,
            &mut c.texture,
            &mut c.radiance,
        ] {
            array.resize(width, 0.0);
        }
        for array in [&mut c.hit, &mut c.material] {
            array.resize(width, 0);
        }
        c.face.resize(width, 0);
        c.textured.resize(width, false);
        let row = Columns {
            dir_x: &mut c.dir_x[..width],
            dir_y: &mut c.dir_y[..width],
            dir_z: &mut c.dir_z[..width],
            depth_m: &mut c.depth_m[..width],
            hit: &mut c.hit[..width],
            face: &mut c.face[..width],
            normal_x: &mut c.normal_x[..width],
            normal_y: &mut c.normal_y[..width],
            normal_z: &mut c.normal_z[..width],
            u: &mut c.u[..width],
            v: &mut c.v[..width],
            material: &mut c.material[..width],
            textured: &mut c.textured[..width],
            light: &mut c.light[..width],
            footprint_m: &mut c.footprint_m[..width],
            texture: &mut c.texture[..width],
            radiance: &mut c.radiance[..width],
        };
        (&self.bands, row)
    }
}

impl Row<'_> {
    /// Column `col`'s ray.
    #[inline(always)]
    fn dir(&self, col: usize) -> Vector3<f32> {
        Vector3::new(self.dir_x[col], self.dir_y[col], self.dir_z[col])
    }

    /// Makes obstacle `index`, `shape` as seen from the rays' origin, what columns `cols` hit
    /// where it is nearer than what they hit so far; the first in scene order stays on a tie.
    #[inline(always)]
    fn nearest(&mut self, cols: Range<usize>, index: u32, shape: &impl RayHit) {
        let (dir_x, dir_y, dir_z) =
            (&self.dir_x[cols.clone()], &self.dir_y[cols.clone()], &self.dir_z[cols.clone()]);
        let (depth_m, hits, faces) =
            (&mut self.depth_m[cols.clone()], &mut self.hit[cols.clone()], &mut self.face[cols]);
        let n = depth_m.len();
        let (dir_x, dir_y, dir_z, hits, faces) =
            (&dir_x[..n], &dir_y[..n], &dir_z[..n], &mut hits[..n], &mut faces[..n]);
        for i in 0..n {
            let (t, face) = shape.hit(&Vector3::new(dir_x[i], dir_y[i], dir_z[i]));
            let nearer = t < depth_m[i];
            depth_m[i] = if nearer { t } else { depth_m[i] };
            hits[i] = if nearer { index } else { hits[i] };
            faces[i] = if nearer { face } else { faces[i] };
        }
    }

    /// Makes `surface` column `col`'s.
    #[inline(always)]
    fn set_surface(&mut self, col: usize, surface: &Surface) {
        (self.normal_x[col], self.normal_y[col], self.normal_z[col]) =
            (surface.normal.x, surface.normal.y, surface.normal.z);
        (self.u[col], self.v[col]) = (surface.u, surface.v);
        self.material[col] = surface.material;
        self.textured[col] = surface.textured;
    }
}

/// Casts every pixel of `view` (the [`CastView`](crate::camera::render::CastView) contract),
/// in the host's widest vector code.
pub(crate) fn cast_view(
    camera: &StereoCamera,
    scene: &Scene,
    view: &View,
    image: Option<(&mut [f32], f32)>,
    depth_m: Option<&mut [f32]>,
    rows: &mut RowBuffers,
) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU was just seen to have AVX2, the one feature the function needs.
        unsafe { cast_view_avx2(camera, scene, view, image, depth_m, rows) };
        return;
    }
    cast_view_in(camera, scene, view, image, depth_m, rows);
}

/// [`cast_view_in`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn cast_view_avx2(
    camera: &StereoCamera,
    scene: &Scene,
    view: &View,
    image: Option<(&mut [f32], f32)>,
    depth_m: Option<&mut [f32]>,
    rows: &mut RowBuffers,
) {
    cast_view_in(camera, scene, view, image, depth_m, rows);
}

/// The caster, inlined into each instruction set's entry point.
#[inline(always)]
fn cast_view_in(
    camera: &StereoCamera,
    scene: &Scene,
    view: &View,
    mut image: Option<(&mut [f32], f32)>,
    mut depth_m: Option<&mut [f32]>,
    rows: &mut RowBuffers,
) {
    let width = camera.column_rays.len();
    rows.bin(camera, scene, view);
    let (bands, mut columns) = rows.row(width);
    let (x_axis, y_axis, z_axis) = (
        view.rotation.column(0).into_owned(),
        view.rotation.column(1).into_owned(),
        view.rotation.column(2).into_owned(),
    );
    let footprint_per_depth = 1.0 / camera.intrinsics().focal_px as f32;
    let shapes = scene.shapes();
    let c = &mut columns;
    for (row, &row_ray) in camera.row_rays.iter().enumerate() {
        let row_dir = z_axis + row_ray * y_axis;
        // The ground, or the sky, behind everything.
        for (col, &column_ray) in camera.column_rays[..width].iter().enumerate() {
            let dir = row_dir + column_ray * x_axis;
            (c.dir_x[col], c.dir_y[col], c.dir_z[col]) = (dir.x, dir.y, dir.z);
            (c.depth_m[col], c.hit[col]) = match Scene::ground_hit(&view.origin, &dir) {
                Some(t) => (t, HIT_GROUND),
                None => (f32::INFINITY, HIT_SKY),
            };
        }
        // The obstacles in front of it, nearest wins (the first in scene order on a tie).
        for &(index, rect) in &bands[row / BAND_ROWS] {
            if !(rect.rows.0..=rect.rows.1).contains(&row) {
                continue;
            }
            let cols = rect.cols.0..rect.cols.1 + 1;
            // A loop per kind of shape, so each is free of branches.
            match shapes[index as usize].seen_from(&view.origin) {
                ShapeFrom::Cuboid(cuboid) => c.nearest(cols, index, &cuboid),
                ShapeFrom::Cylinder(cylinder) => c.nearest(cols, index, &cylinder),
            }
        }
        let pixels = row * width..(row + 1) * width;
        if let Some(depth) = depth_m.as_deref_mut() {
            depth[pixels.clone()].copy_from_slice(c.depth_m);
        }
        if let Some((image, weight)) = image.as_mut() {
            shade_row(camera, scene, view, footprint_per_depth, c);
            for (pixel, &r) in image[pixels].iter_mut().zip(c.radiance.iter()) {
                *pixel += *weight * r;
            }
        }
    }
}

/// The radiance of every column of row `c`, from what its ray hit. Each pass is a loop over
/// columns doing what the reference does per pixel, in the same operations: the ground's
/// surface everywhere, then the obstacles' where they were hit, the light and texel footprint
/// everywhere, the texture of the textured columns, and the radiance.
#[inline(always)]
fn shade_row(camera: &StereoCamera, scene: &Scene, view: &View, footprint_per_depth: f32, c: &mut Row<'_>) {
    let width = c.hit.len();
    for col in 0..width {
        let surface = Scene::ground_surface(&(view.origin + c.depth_m[col] * c.dir(col)));
        c.set_surface(col, &surface);
    }
    for col in 0..width {
        let index = c.hit[col];
        if index < HIT_GROUND {
            let shape = &scene.shapes()[index as usize];
            let surface = shape.surface(index + 1, &view.origin, &c.dir(col), c.depth_m[col], c.face[col]);
            c.set_surface(col, &surface);
        }
    }
    for col in 0..width {
        let normal = Vector3::new(c.normal_x[col], c.normal_y[col], c.normal_z[col]);
        c.light[col] = light(&normal);
        c.footprint_m[col] = texel_footprint_m(&normal, &c.dir(col), c.depth_m[col] * footprint_per_depth);
        c.textured[col] &= c.hit[col] != HIT_SKY;
    }
    camera.texture.sample_batch(Texels {
        material: c.material,
        u: c.u,
        v: c.v,
        footprint_m: c.footprint_m,
        textured: c.textured,
        value: c.texture,
    });
    for col in 0..width {
        c.radiance[col] = if c.hit[col] == HIT_SKY {
            SKY
        } else if c.textured[col] {
            radiance(textured_albedo(c.texture[col]), c.light[col])
        } else {
            radiance(PLAIN_ALBEDO, c.light[col])
        };
    }
}
