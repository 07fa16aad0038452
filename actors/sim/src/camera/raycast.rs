//! The ray caster behind [`StereoCamera::render_moving`]: every ray of a camera starts at the
//! same point, so the acceleration structure is in screen space. Each obstacle is projected
//! once per view to the rectangle of pixels it can cover, and the rectangles are binned into
//! bands of [`BAND_ROWS`] rows; a row then tests only the obstacles of its band whose
//! rectangle spans it, and only over the columns it spans.
//!
//! A row is cast in passes over arrays, one column per entry, so the loops are simple enough
//! for the compiler to vectorise: the ray and the ground (or sky) of every column, then each
//! obstacle over its columns, then the surfaces, then the texture of all textured columns at
//! once ([`Texture::sample_batch`]), the part that costs most. On x86-64 hosts with AVX2 the
//! same code is compiled a second time for AVX2 (found at run time), which gives the texture
//! its 8-lane vector loop and rounding; the arithmetic is IEEE the same either way, so the
//! images are too. The result is bit for bit the per-pixel reference renderer's
//! (`camera/reference.rs`, the test and bench baseline).

use nalgebra::Vector3;

use crate::camera::render::{
    PLAIN_ALBEDO, PixelRect, SKY, StereoCamera, View, light, radiance, texel_footprint_m, textured_albedo,
};
use crate::camera::scene::Scene;
use crate::camera::texture::Texels;

/// Rows per band of the screen-space bins: small enough that a band holds few obstacles that
/// miss a row, large enough that binning costs little against a band's pixels.
const BAND_ROWS: usize = 16;

/// What a column's ray hit first.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Hit {
    Sky,
    Ground,
    /// Obstacle `index` of the scene, entered through `face` ([`Shape::hit`](crate::camera::scene)).
    Shape {
        index: u32,
        face: u8,
    },
}

/// Working memory of the caster, kept between rows, views and frames so casting allocates
/// nothing once warm.
#[derive(Clone, Debug, Default)]
pub(crate) struct RowBuffers {
    /// The obstacles whose projected rectangle meets each band of rows, in scene order.
    bands: Vec<Vec<(u32, PixelRect)>>,
    /// Per column of the row: the ray (NED, scaled so its parameter is the depth), the depth
    /// of the nearest hit (m, infinite for sky), what it hit, and its radiance.
    dir: Vec<Vector3<f32>>,
    depth_m: Vec<f32>,
    hit: Vec<Hit>,
    radiance: Vec<f32>,
    /// The row's textured columns, their light and their texels.
    textured_columns: Vec<u32>,
    textured_light: Vec<f32>,
    texels: Texels,
}

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

    /// Makes the per-column arrays `width` long.
    fn size_columns(&mut self, width: usize) {
        self.dir.resize(width, Vector3::zeros());
        self.depth_m.resize(width, f32::INFINITY);
        self.hit.resize(width, Hit::Sky);
        self.radiance.resize(width, 0.0);
        self.textured_columns.resize(width, 0);
        self.textured_light.resize(width, 0.0);
        self.texels.resize(width);
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
    rows.size_columns(width);
    let (x_axis, y_axis, z_axis) = (
        view.rotation.column(0).into_owned(),
        view.rotation.column(1).into_owned(),
        view.rotation.column(2).into_owned(),
    );
    let footprint_per_depth = 1.0 / camera.intrinsics().focal_px as f32;
    let shapes = scene.shapes();
    for (row, &row_ray) in camera.row_rays.iter().enumerate() {
        let row_dir = z_axis + row_ray * y_axis;
        // The ground, or the sky, behind everything.
        for (col, &column_ray) in camera.column_rays.iter().enumerate() {
            let dir = row_dir + column_ray * x_axis;
            rows.dir[col] = dir;
            (rows.depth_m[col], rows.hit[col]) = match Scene::ground_hit(&view.origin, &dir) {
                Some(t) => (t, Hit::Ground),
                None => (f32::INFINITY, Hit::Sky),
            };
        }
        // The obstacles in front of it, nearest wins (the first in scene order on a tie).
        for &(index, rect) in &rows.bands[row / BAND_ROWS] {
            if !(rect.rows.0..=rect.rows.1).contains(&row) {
                continue;
            }
            let shape = &shapes[index as usize];
            for col in rect.cols.0..=rect.cols.1 {
                if let Some((t, face)) = shape.hit(&view.origin, &rows.dir[col])
                    && t < rows.depth_m[col]
                {
                    (rows.depth_m[col], rows.hit[col]) = (t, Hit::Shape { index, face });
                }
            }
        }
        let pixels = row * width..(row + 1) * width;
        if let Some(depth) = depth_m.as_deref_mut() {
            depth[pixels.clone()].copy_from_slice(&rows.depth_m);
        }
        if let Some((image, weight)) = image.as_mut() {
            shade_row(camera, scene, view, footprint_per_depth, rows);
            for (pixel, &r) in image[pixels].iter_mut().zip(&rows.radiance) {
                *pixel += *weight * r;
            }
        }
    }
}

/// The radiance of every column of the row in `rows`, from what its ray hit.
#[inline(always)]
fn shade_row(
    camera: &StereoCamera,
    scene: &Scene,
    view: &View,
    footprint_per_depth: f32,
    rows: &mut RowBuffers,
) {
    // Indexed writes into arrays sized once, not pushes: the loop keeps its pointers in
    // registers.
    let mut n = 0;
    let (columns, lights, texels) = (&mut rows.textured_columns, &mut rows.textured_light, &mut rows.texels);
    for col in 0..rows.hit.len() {
        let (t, dir) = (rows.depth_m[col], rows.dir[col]);
        let surface = match rows.hit[col] {
            Hit::Sky => {
                rows.radiance[col] = SKY;
                continue;
            }
            Hit::Ground => Scene::ground_surface(&(view.origin + t * dir)),
            Hit::Shape { index, face } => {
                scene.shapes()[index as usize].surface(index + 1, &view.origin, &dir, t, face)
            }
        };
        let light = light(&surface.normal);
        if surface.textured {
            (columns[n], lights[n]) = (col as u32, light);
            texels.material[n] = surface.material;
            (texels.u[n], texels.v[n]) = (surface.u, surface.v);
            texels.footprint_m[n] = texel_footprint_m(&surface.normal, &dir, t * footprint_per_depth);
            n += 1;
        } else {
            rows.radiance[col] = radiance(PLAIN_ALBEDO, light);
        }
    }
    camera.texture.sample_batch(texels, n);
    for ((&col, &light), &texture) in columns[..n].iter().zip(&lights[..n]).zip(&texels.value[..n]) {
        rows.radiance[col as usize] = radiance(textured_albedo(texture), light);
    }
}
