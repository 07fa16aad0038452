//! The reference renderer: the caster the simulator first had, one pixel at a time, every
//! obstacle whose projected rectangle covers the pixel tested against its ray, each texel
//! sampled alone. Kept only for the tests and the render bench (feature `render-reference`),
//! which check the fast caster (`camera/raycast.rs`) against it and time the two side by side.

use nalgebra::Vector3;

use crate::camera::raycast::RowBuffers;
use crate::camera::render::{
    CapturePose, PLAIN_ALBEDO, PixelRect, RenderBuffers, SKY, StereoCamera, StereoRender, Threads, View,
    light, radiance, texel_footprint_m, textured_albedo,
};
use crate::camera::scene::{Scene, Surface};

/// [`StereoCamera::render_moving`] by the reference caster, on the calling thread alone.
pub fn render_moving_reference(
    camera: &StereoCamera,
    scene: &Scene,
    pose: &CapturePose,
    sequence: u64,
    buffers: &mut RenderBuffers,
) -> StereoRender {
    camera.render_moving_by(cast_view_per_pixel, Threads::One, scene, pose, sequence, buffers)
}

/// Casts every pixel of one camera (the [`CastView`](crate::camera::render::CastView)
/// contract), one at a time.
fn cast_view_per_pixel(
    camera: &StereoCamera,
    scene: &Scene,
    view: &View,
    mut image: Option<(&mut [f32], f32)>,
    mut depth_m: Option<&mut [f32]>,
    _rows: &mut RowBuffers,
) {
    let width = camera.column_rays.len();
    let bounds: Vec<(usize, PixelRect)> = scene
        .shapes()
        .iter()
        .enumerate()
        .filter_map(|(i, shape)| camera.projection(shape, view).map(|rect| (i, rect)))
        .collect();
    let (x_axis, y_axis, z_axis) = (
        view.rotation.column(0).into_owned(),
        view.rotation.column(1).into_owned(),
        view.rotation.column(2).into_owned(),
    );
    let footprint_per_depth = 1.0 / camera.intrinsics().focal_px as f32;
    let mut in_row: Vec<(usize, PixelRect)> = Vec::with_capacity(bounds.len());
    for (row, &row_ray) in camera.row_rays.iter().enumerate() {
        in_row.clear();
        in_row.extend(bounds.iter().filter(|(_, r)| (r.rows.0..=r.rows.1).contains(&row)));
        let row_dir = z_axis + row_ray * y_axis;
        for (col, &column_ray) in camera.column_rays.iter().enumerate() {
            let dir = row_dir + column_ray * x_axis;
            let mut nearest: Option<(f32, Option<(usize, u8)>)> =
                Scene::ground_hit(&view.origin, &dir).map(|t| (t, None));
            for &(i, rect) in &in_row {
                if !(rect.cols.0..=rect.cols.1).contains(&col) {
                    continue;
                }
                if let Some((t, face)) = scene.shapes()[i].hit(&view.origin, &dir)
                    && nearest.is_none_or(|(best, _)| t < best)
                {
                    nearest = Some((t, Some((i, face))));
                }
            }
            let pixel = row * width + col;
            let Some((t, what)) = nearest else {
                if let Some((image, weight)) = image.as_mut() {
                    image[pixel] += *weight * SKY;
                }
                continue;
            };
            if let Some((image, weight)) = image.as_mut() {
                let surface = match what {
                    None => Scene::ground_surface(&(view.origin + t * dir)),
                    Some((i, face)) => scene.shapes()[i].surface(i as u32 + 1, &view.origin, &dir, t, face),
                };
                image[pixel] += *weight * shade(camera, &surface, &dir, t * footprint_per_depth);
            }
            if let Some(depth) = depth_m.as_deref_mut() {
                depth[pixel] = t;
            }
        }
    }
}

/// Radiance of `surface` seen along `dir` with a pixel footprint of `footprint_m` (m) across
/// the line of sight, in grey levels at unit gain (not rounded).
fn shade(camera: &StereoCamera, surface: &Surface, dir: &Vector3<f32>, footprint_m: f32) -> f32 {
    let albedo = if surface.textured {
        let footprint_m = texel_footprint_m(&surface.normal, dir, footprint_m);
        textured_albedo(camera.texture.sample(surface.material, surface.u, surface.v, footprint_m))
    } else {
        PLAIN_ALBEDO
    };
    radiance(albedo, light(&surface.normal))
}
