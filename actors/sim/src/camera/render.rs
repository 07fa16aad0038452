//! The stereo renderer: one ray per pixel from each camera into the [`Scene`], shaded with
//! procedural texture and a fixed sun, plus the left camera's true depth.
//!
//! Optional camera effects, all off by default and all deterministic (a function of the
//! parameters, the pose and the frame's sequence number only):
//! * motion blur: the scene integrated over the exposure window, centred on the capture
//!   instant, as the average of `blur_samples` renders at poses extrapolated from the body's
//!   velocity and rate;
//! * exposure: a per-frame global gain (auto-exposure flicker) and a fixed right/left gain
//!   mismatch, applied to the scene's radiance before quantisation to 8 bits;
//! * Gaussian pixel noise, added with the gain and before quantisation.

use kestrel_proto::Time;
use kestrel_proto::attitude::unit_quaternion;
use kestrel_proto::messages::{FrameSizeError, GroundTruth, StereoFrame};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal, StandardNormal};
use rand_pcg::Pcg64;

use crate::camera::params::{Intrinsics, StereoCameraParams};
use crate::camera::raycast::{RowBuffers, cast_view};
use crate::camera::scene::{Scene, Shape};
use crate::camera::texture::Texture;
use crate::error::InvalidParam;

/// Grey level of the sky (uniform).
pub(crate) const SKY: f32 = 200.0;
/// Albedo of a textureless surface.
pub(crate) const PLAIN_ALBEDO: f32 = 0.6;
/// Unit vector from a surface towards the sun (NED): high, to the south-east.
const TOWARDS_SUN: [f32; 3] = [-0.3, 0.4, -0.866];
/// Light everywhere, and the part of it from the sun.
const AMBIENT: f32 = 0.5;
const SUNLIGHT: f32 = 0.5;
/// Corners nearer than this in front of a camera make an obstacle's projection unbounded (m).
const NEAR_M: f32 = 0.01;
/// Mixed into the seed of the exposure gains so they draw from another stream than the noise.
const GAIN_STREAM: u64 = 0x6A09_E667_F3BC_C908;
/// The frame sequence number is spread over the seed's bits by this odd constant (2⁶⁴/φ), so
/// neighbouring frames get unrelated noise and gains.
const SEQUENCE_SPREAD: u64 = 0x9E37_79B9_7F4A_7C15;

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
    pub(crate) column_rays: Vec<f32>,
    pub(crate) row_rays: Vec<f32>,
    pub(crate) texture: Texture,
    /// Per-pixel image noise (grey levels), if any.
    noise: Option<Normal<f64>>,
    /// Whether renders cast the two cameras at once.
    threads: Threads,
}

/// The body's true state at a frame's capture instant: the pose the frame shows and, for
/// motion blur, how it is moving.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CapturePose {
    /// Body origin, north/east/down from home (m).
    pub position_ned_m: Vector3<f64>,
    /// Rotation of body FRD into NED.
    pub attitude: UnitQuaternion<f64>,
    /// Velocity north/east/down (m/s).
    pub velocity_ned_m_s: Vector3<f64>,
    /// Angular rate about body forward, right, down (rad/s).
    pub angular_velocity_frd_rad_s: Vector3<f64>,
}

impl From<&GroundTruth> for CapturePose {
    /// The simulator's true state as a capture pose.
    fn from(truth: &GroundTruth) -> CapturePose {
        CapturePose {
            position_ned_m: Vector3::from(truth.position_ned_m),
            // The simulator's own attitude is a rotation by construction.
            attitude: unit_quaternion(truth.attitude).unwrap_or_else(|_| UnitQuaternion::identity()),
            velocity_ned_m_s: Vector3::from(truth.velocity_ned_m_s),
            angular_velocity_frd_rad_s: Vector3::from(truth.angular_velocity_rad_s),
        }
    }
}

impl CapturePose {
    /// A body at rest at `position_ned_m`, turned by `attitude` (body FRD → NED).
    pub fn still(position_ned_m: Vector3<f64>, attitude: UnitQuaternion<f64>) -> CapturePose {
        CapturePose {
            position_ned_m,
            attitude,
            velocity_ned_m_s: Vector3::zeros(),
            angular_velocity_frd_rad_s: Vector3::zeros(),
        }
    }

    /// Position and attitude `dt_s` seconds after the capture instant (before it when
    /// negative), at constant velocity and body rate. Over an exposure of a few milliseconds
    /// the neglected acceleration term is below a millimetre.
    pub fn at(&self, dt_s: f64) -> (Vector3<f64>, UnitQuaternion<f64>) {
        (
            self.position_ned_m + self.velocity_ned_m_s * dt_s,
            // Body rates turn the body frame: q(t + dt) = q(t) ⊗ exp(ω·dt).
            self.attitude * UnitQuaternion::from_scaled_axis(self.angular_velocity_frd_rad_s * dt_s),
        )
    }

    fn is_still(&self) -> bool {
        self.velocity_ned_m_s == Vector3::zeros() && self.angular_velocity_frd_rad_s == Vector3::zeros()
    }
}

/// Working memory of [`StereoCamera::render_moving`], reused from frame to frame so a render
/// allocates only the images and depth it returns.
#[derive(Clone, Debug, Default)]
pub struct RenderBuffers {
    /// Scene radiance per pixel (grey levels at unit gain), summed over the exposure's
    /// sub-images with their weights.
    left: Vec<f32>,
    right: Vec<f32>,
    /// The ray caster's per-row working memory and screen bins, one per camera.
    rows: RowBuffers,
    right_rows: RowBuffers,
}

/// How many threads a render casts on: the two cameras at once on hosts with more than one
/// CPU, which halves a render's wall time without changing a pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Threads {
    One,
    Two,
}

impl RenderBuffers {
    /// Zeroes both accumulators at `pixels` pixels, keeping their allocations.
    fn reset(&mut self, pixels: usize) {
        for buffer in [&mut self.left, &mut self.right] {
            buffer.clear();
            buffer.resize(pixels, 0.0);
        }
    }
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
pub(crate) struct View {
    pub(crate) origin: Vector3<f32>,
    /// Columns: the camera's x, y, z axes in NED.
    pub(crate) rotation: Matrix3<f32>,
}

/// Renders one camera's `view` of a scene: adds `weight` times each pixel's radiance (grey
/// levels) to `image` and writes its depth (m, infinite for sky) into `depth_m`, either of
/// which may be left out; [`cast_view`] does it, and the reference renderer the slow way.
pub(crate) type CastView =
    fn(&StereoCamera, &Scene, &View, Option<(&mut [f32], f32)>, Option<&mut [f32]>, &mut RowBuffers);

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
            threads: match std::thread::available_parallelism() {
                Ok(cpus) if cpus.get() > 1 => Threads::Two,
                _ => Threads::One,
            },
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

    /// Renders both cameras with the body at rest at `position_ned_m` (m from home) turned by
    /// `attitude` (body FRD → NED): no motion blur; `sequence` seeds this frame's noise and
    /// exposure gain.
    pub fn render(
        &self,
        scene: &Scene,
        position_ned_m: &Vector3<f64>,
        attitude: &UnitQuaternion<f64>,
        sequence: u64,
    ) -> StereoRender {
        let pose = CapturePose::still(*position_ned_m, *attitude);
        self.render_moving(scene, &pose, sequence, &mut RenderBuffers::default())
    }

    /// Renders both cameras as captured with the body at `pose`; `sequence` seeds this frame's
    /// noise and exposure gain, `buffers` is working memory (any, e.g. the last frame's).
    ///
    /// With an exposure time `T` and a moving body, each image is the mean of `blur_samples`
    /// renders at `T·((i + ½)/n − ½)` s from the capture instant (the midpoint rule over the
    /// window), so a point moving `s` px/s on the image is smeared over `s·T` px, centred on
    /// where it is at the capture instant. That costs `blur_samples` times a still render,
    /// plus one depth-only pass of the left camera when `blur_samples` is even; the depth is
    /// always the capture instant's. A body at rest, or `T = 0`, renders once.
    pub fn render_moving(
        &self,
        scene: &Scene,
        pose: &CapturePose,
        sequence: u64,
        buffers: &mut RenderBuffers,
    ) -> StereoRender {
        self.render_moving_by(cast_view, self.threads, scene, pose, sequence, buffers)
    }

    /// [`StereoCamera::render_moving`] with each view cast by `cast`, the right camera's on a
    /// second thread while this one casts the left's if `threads` is [`Threads::Two`].
    pub(crate) fn render_moving_by(
        &self,
        cast: CastView,
        threads: Threads,
        scene: &Scene,
        pose: &CapturePose,
        sequence: u64,
        buffers: &mut RenderBuffers,
    ) -> StereoRender {
        let (width, height) = (self.params.width_px, self.params.height_px);
        let pixels = width as usize * height as usize;
        buffers.reset(pixels);
        let mut depth_m = vec![f32::INFINITY; pixels];
        let exposure_s = self.params.exposure_time_s;
        let samples = if exposure_s > 0.0 && !pose.is_still() { self.params.blur_samples } else { 1 };
        let weight = 1.0 / samples as f32;
        // With an odd count the middle sample falls on the capture instant exactly.
        let centre = (samples % 2 == 1).then_some(samples / 2);
        let at = |i: u32| pose.at(exposure_s * ((f64::from(i) + 0.5) / f64::from(samples) - 0.5));
        let left_side = |image: &mut Vec<f32>, rows: &mut RowBuffers, depth_m: &mut [f32]| {
            for i in 0..samples {
                let (left, _) = self.views(&at(i));
                let depth = (Some(i) == centre).then_some(&mut *depth_m);
                cast(self, scene, &left, Some((image, weight)), depth, rows);
            }
            if centre.is_none() {
                let (left, _) = self.views(&pose.at(0.0));
                cast(self, scene, &left, None, Some(depth_m), rows);
            }
        };
        let right_side = |image: &mut Vec<f32>, rows: &mut RowBuffers| {
            for i in 0..samples {
                let (_, right) = self.views(&at(i));
                cast(self, scene, &right, Some((image, weight)), None, rows);
            }
        };
        let RenderBuffers { left, right, rows, right_rows } = buffers;
        // The two cameras share nothing but the scene, so either order, or both at once, gives
        // the same images; a thread the host will not start leaves the right one for after.
        let right_done = threads == Threads::Two
            && std::thread::scope(|scope| {
                let spawned =
                    std::thread::Builder::new().spawn_scoped(scope, || right_side(right, right_rows)).is_ok();
                left_side(left, rows, &mut depth_m);
                spawned
            });
        if !right_done {
            if threads == Threads::One {
                left_side(left, rows, &mut depth_m);
            }
            right_side(right, right_rows);
        }
        let (left_gain, right_gain) = self.exposure_gains(sequence);
        let mut noise = self.noise.as_ref().map(|noise| {
            (noise, Pcg64::seed_from_u64(self.params.seed ^ sequence.wrapping_mul(SEQUENCE_SPREAD)))
        });
        let left = quantise(&buffers.left, left_gain as f32, noise.as_mut());
        let right = quantise(&buffers.right, right_gain as f32, noise.as_mut());
        StereoRender { width, height, left, right, depth: DepthImage { width, height, depth_m } }
    }

    /// The gains frame `sequence` applies to the scene's radiance, `(left, right)`: a global
    /// gain `exp(exposure_gain_std·z)` with `z` standard normal, drawn afresh for each frame
    /// from the seed and the sequence number (so any frame renders alone, in any order), times
    /// `1 + lr_gain_mismatch` for the right camera. `(1, 1)` with the defaults.
    pub fn exposure_gains(&self, sequence: u64) -> (f64, f64) {
        let std = self.params.exposure_gain_std;
        let gain = if std > 0.0 {
            let mut rng = Pcg64::seed_from_u64(
                (self.params.seed ^ GAIN_STREAM).wrapping_add(sequence.wrapping_mul(SEQUENCE_SPREAD)),
            );
            let z: f64 = StandardNormal.sample(&mut rng);
            (std * z).exp()
        } else {
            1.0
        };
        (gain, gain * (1.0 + self.params.lr_gain_mismatch))
    }

    /// Where the left and right cameras are and how they are turned with the body at
    /// `(position_ned_m, attitude)`.
    fn views(&self, (position_ned_m, attitude): &(Vector3<f64>, UnitQuaternion<f64>)) -> (View, View) {
        let body_to_ned = attitude.to_rotation_matrix().into_inner();
        // Camera x, y, z are body right, down, forward.
        let camera_to_body = Matrix3::new(0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
        let rotation: Matrix3<f32> = (body_to_ned * camera_to_body).cast();
        let mount = position_ned_m + body_to_ned * Vector3::from(self.params.mount_frd_m);
        let half_baseline = body_to_ned * Vector3::new(0.0, self.params.baseline_m / 2.0, 0.0);
        (
            View { origin: (mount - half_baseline).cast(), rotation },
            View { origin: (mount + half_baseline).cast(), rotation },
        )
    }

    /// The pixels `shape` can cover in `view` (inclusive ranges), or `None` when it is wholly
    /// behind the camera or outside the image.
    pub(crate) fn projection(&self, shape: &Shape, view: &View) -> Option<PixelRect> {
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
pub(crate) struct PixelRect {
    pub(crate) cols: (usize, usize),
    pub(crate) rows: (usize, usize),
}

/// Light falling on a surface of outward unit normal `normal` (NED): the ambient light and the
/// sun's share of it, 0.5 to 1.
#[inline(always)]
pub(crate) fn light(normal: &Vector3<f32>) -> f32 {
    AMBIENT + SUNLIGHT * normal.dot(&Vector3::from(TOWARDS_SUN)).max(0.0)
}

/// The footprint the texture is sampled at (m): the pixel's footprint `footprint_m` across the
/// line of sight `dir`, stretched by the slant of a surface of normal `normal`, at most 5×.
#[inline(always)]
pub(crate) fn texel_footprint_m(normal: &Vector3<f32>, dir: &Vector3<f32>, footprint_m: f32) -> f32 {
    let incidence = (normal.dot(dir).abs() / dir.norm()).max(0.2);
    footprint_m / incidence
}

/// Albedo of a textured surface whose texture reads `texture` (0..1).
#[inline(always)]
pub(crate) fn textured_albedo(texture: f32) -> f32 {
    0.15 + 0.8 * texture
}

/// Radiance (grey levels at unit gain, not rounded) of a surface of `albedo` under `light`.
#[inline(always)]
pub(crate) fn radiance(albedo: f32, light: f32) -> f32 {
    255.0 * albedo * light
}

/// The 8-bit image of `radiance` (grey levels at unit gain) times `gain`, plus `noise` (grey
/// levels) if any, rounded and saturated at 0 and 255.
fn quantise(radiance: &[f32], gain: f32, noise: Option<&mut (&Normal<f64>, Pcg64)>) -> Vec<u8> {
    match noise {
        None => radiance.iter().map(|&r| grey_level(gain * r)).collect(),
        Some((noise, rng)) => radiance
            .iter()
            .map(|&r| (f64::from(gain * r) + noise.sample(rng)).round().clamp(0.0, 255.0) as u8)
            .collect(),
    }
}

/// `x.round().clamp(0.0, 255.0) as u8` (NaN to 0) in operations that vectorise on any x86-64,
/// which has no rounding instruction before SSE 4.1: clamping first changes nothing, and the
/// fraction left after truncation is exact.
#[inline(always)]
fn grey_level(x: f32) -> u8 {
    let level = if x.is_nan() { 0.0 } else { x.clamp(0.0, 255.0) };
    // SAFETY: `level` is in [0, 255], so it truncates to a u32.
    let whole = unsafe { level.to_int_unchecked::<u32>() };
    (whole + u32::from(level - whole as f32 >= 0.5)) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    proptest::proptest! {
        /// On random bit patterns (NaNs, infinities and subnormals among them) and on grey
        /// levels near half-integers.
        #[test]
        fn grey_levels_round_and_saturate_as_the_float_operations_do(
            bits in proptest::num::u32::ANY,
            level in -2.0f32..258.0,
        ) {
            for x in [f32::from_bits(bits), level, level.floor() + 0.5, (level.floor() + 0.5).next_down()] {
                proptest::prop_assert_eq!(grey_level(x), x.round().clamp(0.0, 255.0) as u8, "{}", x);
            }
        }
    }
}
