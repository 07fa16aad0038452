//! The stereo renderer: one ray per pixel from each camera into the [`Scene`], shaded with
//! procedural texture and a fixed sun, plus the left camera's true depth.

use kestrel_proto::Time;
use kestrel_proto::messages::{FrameSizeError, StereoFrame};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use rand_pcg::Pcg64;

use crate::camera::params::{Intrinsics, StereoCameraParams};
use crate::camera::scene::{Scene, Shape, Surface};
use crate::camera::texture::Texture;
use crate::error::InvalidParam;

/// Grey level of the sky (uniform).
const SKY: u8 = 200;
/// Grey level of a textureless surface lit by the ambient light alone.
const PLAIN_ALBEDO: f32 = 0.6;
/// Unit vector from a surface towards the sun (NED): high, to the south-east.
const TOWARDS_SUN: [f32; 3] = [-0.3, 0.4, -0.866];
/// Light everywhere, and the part of it from the sun.
const AMBIENT: f32 = 0.5;
const SUNLIGHT: f32 = 0.5;
/// Corners nearer than this in front of a camera make an obstacle's projection unbounded (m).
const NEAR_M: f32 = 0.01;

/// A rectified stereo pair rendering a [`Scene`] by ray casting; pure and deterministic (the
/// same scene, pose, parameters and sequence number give the same images).
///
/// Camera frame: x right, y down, z forward along the optical axis. Both cameras look along
/// body +x (FRD) with parallel optical axes; the left one is `baseline_m/2` to the left of
/// `mount_frd_m`, the right one as far to its right.
#[derive(Clone, Debug)]
pub struct StereoCamera {
    params: StereoCameraParams,
    intrinsics: Intrinsics,
    /// `(col − cx)/f` per column and `(row − cy)/f` per row: the camera-frame ray of a pixel is
    /// `(column_rays[col], row_rays[row], 1)`, so a hit's ray parameter is its depth.
    column_rays: Vec<f32>,
    row_rays: Vec<f32>,
    texture: Texture,
    /// Per-pixel image noise (grey levels), if any.
    noise: Option<Normal<f64>>,
}

/// One rendered stereo pair with the left camera's true depth.
#[derive(Clone, Debug, PartialEq)]
pub struct StereoRender {
    /// Image width (px).
    pub width: u32,
    /// Image height (px).
    pub height: u32,
    /// Left image, 8-bit grey, row-major.
    pub left: Vec<u8>,
    /// Right image, 8-bit grey, row-major.
    pub right: Vec<u8>,
    /// True depth per left pixel.
    pub depth: DepthImage,
}

/// Depth per pixel of the left camera: distance along its optical axis (m), `f32::INFINITY`
/// where the pixel sees sky.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthImage {
    /// Width (px).
    pub width: u32,
    /// Height (px).
    pub height: u32,
    /// Row-major depths (m).
    pub depth_m: Vec<f32>,
}

impl DepthImage {
    /// Depth at column `col`, row `row` (m); `None` for sky or outside the image.
    pub fn at(&self, col: u32, row: u32) -> Option<f32> {
        if col >= self.width || row >= self.height {
            return None;
        }
        Some(self.depth_m[(row * self.width + col) as usize]).filter(|d| d.is_finite())
    }
}

impl StereoRender {
    /// The images as a frame captured at `time`, and the true depth kept aside for scoring.
    pub fn into_frame(self, time: Time, sequence: u64) -> Result<(StereoFrame, DepthImage), FrameSizeError> {
        let frame = StereoFrame::new(time, sequence, self.width, self.height, self.left, self.right)?;
        Ok((frame, self.depth))
    }
}

/// Where one camera is and how it is turned, in NED, single precision.
struct View {
    origin: Vector3<f32>,
    /// Columns: the camera's x, y, z axes in NED.
    rotation: Matrix3<f32>,
}

impl StereoCamera {
    /// A rig with checked `params`.
    pub fn new(params: &StereoCameraParams) -> Result<StereoCamera, InvalidParam> {
        params.validate()?;
        let k = params.intrinsics();
        let noise = (params.noise_std > 0.0)
            .then(|| Normal::new(0.0, params.noise_std))
            .transpose()
            .map_err(|e| InvalidParam::new("noise_std", e.to_string()))?;
        let rays = |n: u32, c: f64| (0..n).map(|i| ((f64::from(i) - c) / k.focal_px) as f32).collect();
        Ok(StereoCamera {
            params: params.clone(),
            intrinsics: k,
            column_rays: rays(params.width_px, k.cx_px),
            row_rays: rays(params.height_px, k.cy_px),
            texture: Texture::new(params.seed),
            noise,
        })
    }

    /// The pinhole model of both cameras.
    pub fn intrinsics(&self) -> &Intrinsics {
        &self.intrinsics
    }

    /// The parameters the rig was built with.
    pub fn params(&self) -> &StereoCameraParams {
        &self.params
    }

    /// Renders both cameras with the body at `position_ned_m` (m from home) turned by
    /// `attitude` (body FRD → NED); `sequence` seeds this frame's image noise.
    pub fn render(
        &self,
        scene: &Scene,
        position_ned_m: &Vector3<f64>,
        attitude: &UnitQuaternion<f64>,
        sequence: u64,
    ) -> StereoRender {
        let body_to_ned = attitude.to_rotation_matrix().into_inner();
        // Camera x, y, z are body right, down, forward.
        let camera_to_body = Matrix3::new(0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
        let rotation: Matrix3<f32> = (body_to_ned * camera_to_body).cast();
        let mount = position_ned_m + body_to_ned * Vector3::from(self.params.mount_frd_m);
        let half_baseline = body_to_ned * Vector3::new(0.0, self.params.baseline_m / 2.0, 0.0);
        let left = View { origin: (mount - half_baseline).cast(), rotation };
        let right = View { origin: (mount + half_baseline).cast(), rotation };

        let pixels = self.params.width_px as usize * self.params.height_px as usize;
        let mut depth_m = vec![f32::INFINITY; pixels];
        let mut left_image = vec![SKY; pixels];
        let mut right_image = vec![SKY; pixels];
        self.render_view(scene, &left, &mut left_image, Some(&mut depth_m));
        self.render_view(scene, &right, &mut right_image, None);
        if let Some(noise) = &self.noise {
            let mut rng =
                Pcg64::seed_from_u64(self.params.seed ^ sequence.wrapping_mul(0x9E37_79B9_7F4A_7C15));
            add_noise(&mut left_image, noise, &mut rng);
            add_noise(&mut right_image, noise, &mut rng);
        }
        let (width, height) = (self.params.width_px, self.params.height_px);
        StereoRender {
            width,
            height,
            left: left_image,
            right: right_image,
            depth: DepthImage { width, height, depth_m },
        }
    }

    /// Casts every pixel of one camera into `image` (and its depth into `depth_m`).
    fn render_view(&self, scene: &Scene, view: &View, image: &mut [u8], mut depth_m: Option<&mut Vec<f32>>) {
        let width = self.column_rays.len();
        let bounds: Vec<(usize, PixelRect)> = scene
            .shapes()
            .iter()
            .enumerate()
            .filter_map(|(i, shape)| self.projection(shape, view).map(|rect| (i, rect)))
            .collect();
        let (x_axis, y_axis, z_axis) = (
            view.rotation.column(0).into_owned(),
            view.rotation.column(1).into_owned(),
            view.rotation.column(2).into_owned(),
        );
        let footprint_per_depth = 1.0 / self.intrinsics.focal_px as f32;
        let mut in_row: Vec<(usize, PixelRect)> = Vec::with_capacity(bounds.len());
        for (row, &row_ray) in self.row_rays.iter().enumerate() {
            in_row.clear();
            in_row.extend(bounds.iter().filter(|(_, r)| (r.rows.0..=r.rows.1).contains(&row)));
            let row_dir = z_axis + row_ray * y_axis;
            for (col, &column_ray) in self.column_rays.iter().enumerate() {
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
                let Some((t, what)) = nearest else { continue };
                let surface = match what {
                    None => Scene::ground_surface(&(view.origin + t * dir)),
                    Some((i, face)) => scene.shapes()[i].surface(i as u32 + 1, &view.origin, &dir, t, face),
                };
                image[row * width + col] = self.shade(&surface, &dir, t * footprint_per_depth);
                if let Some(depth) = depth_m.as_deref_mut() {
                    depth[row * width + col] = t;
                }
            }
        }
    }

    /// Grey level of `surface` seen along `dir` with a pixel footprint of `footprint_m` (m)
    /// across the line of sight.
    fn shade(&self, surface: &Surface, dir: &Vector3<f32>, footprint_m: f32) -> u8 {
        let sun = Vector3::from(TOWARDS_SUN);
        let light = AMBIENT + SUNLIGHT * surface.normal.dot(&sun).max(0.0);
        let albedo = if surface.textured {
            let incidence = (surface.normal.dot(dir).abs() / dir.norm()).max(0.2);
            0.15 + 0.8 * self.texture.sample(surface.material, surface.u, surface.v, footprint_m / incidence)
        } else {
            PLAIN_ALBEDO
        };
        (255.0 * albedo * light).round().clamp(0.0, 255.0) as u8
    }

    /// The pixels `shape` can cover in `view` (inclusive ranges), or `None` when it is wholly
    /// behind the camera or outside the image.
    fn projection(&self, shape: &Shape, view: &View) -> Option<PixelRect> {
        let (w, h) = (self.params.width_px as f32, self.params.height_px as f32);
        let k = &self.intrinsics;
        let (f, cx, cy) = (k.focal_px as f32, k.cx_px as f32, k.cy_px as f32);
        let corners = shape.bounding_corners().map(|c| view.rotation.tr_mul(&(c - view.origin)));
        if corners.iter().all(|c| c.z <= 0.0) {
            return None;
        }
        let full = PixelRect { cols: (0, w as usize - 1), rows: (0, h as usize - 1) };
        if corners.iter().any(|c| c.z < NEAR_M) {
            return Some(full);
        }
        let (mut u0, mut u1, mut v0, mut v1) =
            (f32::INFINITY, f32::NEG_INFINITY, f32::INFINITY, f32::NEG_INFINITY);
        for c in &corners {
            let (u, v) = (f * c.x / c.z + cx, f * c.y / c.z + cy);
            (u0, u1, v0, v1) = (u0.min(u), u1.max(u), v0.min(v), v1.max(v));
        }
        if u1 < -1.0 || v1 < -1.0 || u0 > w || v0 > h {
            return None;
        }
        let clamp = |x: f32, n: f32| x.clamp(0.0, n - 1.0) as usize;
        Some(PixelRect {
            cols: (clamp(u0.floor() - 1.0, w), clamp(u1.ceil() + 1.0, w)),
            rows: (clamp(v0.floor() - 1.0, h), clamp(v1.ceil() + 1.0, h)),
        })
    }
}

/// An inclusive rectangle of pixels.
#[derive(Clone, Copy, Debug)]
struct PixelRect {
    cols: (usize, usize),
    rows: (usize, usize),
}

/// Adds `noise` (grey levels) to every pixel, saturating.
fn add_noise(image: &mut [u8], noise: &Normal<f64>, rng: &mut Pcg64) {
    for p in image {
        *p = (f64::from(*p) + noise.sample(rng)).round().clamp(0.0, 255.0) as u8;
    }
}
