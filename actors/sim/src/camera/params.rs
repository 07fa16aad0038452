//! The stereo rig's parameters and the pinhole intrinsics they give.

use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, finite, non_negative, positive};

/// A rectified stereo pair of identical pinhole cameras, as the `camera` table of a config
/// gives it. The defaults are a ZED-like rig: VGA, 12 cm baseline, 110° horizontal field of
/// view, mounted at the body origin looking forward.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StereoCameraParams {
    /// Image width (px).
    pub width_px: u32,
    /// Image height (px).
    pub height_px: u32,
    /// Horizontal field of view (degrees), in (0, 180).
    pub horizontal_fov_deg: f64,
    /// Distance between the two optical centres, along body right (m).
    pub baseline_m: f64,
    /// Midpoint between the optical centres in the body FRD frame (m).
    pub mount_frd_m: [f64; 3],
    /// Standard deviation of the Gaussian noise added to every pixel (grey levels); 0 for none.
    pub noise_std: f64,
    /// Exposure time (s), in [0, 0.1], for motion blur: each image integrates the scene over
    /// a window this long centred on the capture instant (so the blurred image is centred on
    /// the stamped pose and agrees with the true depth, which stays the capture instant's).
    /// 0 renders the capture instant alone.
    pub exposure_time_s: f64,
    /// Sub-images averaged over the exposure window, in 1..=64: a blur `w` px wide is drawn
    /// as this many copies `w/blur_samples` px apart, so use about one per pixel of the
    /// widest blur expected. Each costs a full render of both cameras (the render bench
    /// times one), and an even count one more depth-only pass; unused while the body is at rest.
    pub blur_samples: u32,
    /// Auto-exposure flicker: standard deviation of the natural log of a per-frame global gain
    /// on both images, in [0, 1] (0.1 ≈ ±10 % frame to frame); 0 for a constant gain of 1.
    pub exposure_gain_std: f64,
    /// Fixed gain mismatch of the right camera against the left, in [-0.5, 0.5]: its pixels are
    /// `1 + lr_gain_mismatch` times brighter (0.05 = 5 % brighter), as on real rigs whose two
    /// sensors and lenses never quite match.
    pub lr_gain_mismatch: f64,
    /// Seed of the surface texture, the image noise and the exposure gains.
    pub seed: u64,
}

impl Default for StereoCameraParams {
    fn default() -> StereoCameraParams {
        StereoCameraParams {
            width_px: 640,
            height_px: 480,
            horizontal_fov_deg: 110.0,
            baseline_m: 0.12,
            mount_frd_m: [0.0; 3],
            noise_std: 0.0,
            exposure_time_s: 0.0,
            blur_samples: 5,
            exposure_gain_std: 0.0,
            lr_gain_mismatch: 0.0,
            seed: 1,
        }
    }
}

/// Largest image side the renderer accepts (px).
const MAX_SIDE_PX: u32 = 8192;
/// Longest exposure accepted (s): past this the blur smears everything an avoider needs.
const MAX_EXPOSURE_S: f64 = 0.1;
/// Most sub-images per exposure.
const MAX_BLUR_SAMPLES: u32 = 64;

impl StereoCameraParams {
    /// Checks every field; the error names the offending one.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        for (field, side) in [("width_px", self.width_px), ("height_px", self.height_px)] {
            if !(2..=MAX_SIDE_PX).contains(&side) {
                return Err(InvalidParam::new(field, format!("must be in 2..={MAX_SIDE_PX}, got {side}")));
            }
        }
        let fov = self.horizontal_fov_deg;
        if !(fov.is_finite() && fov > 0.0 && fov < 180.0) {
            return Err(InvalidParam::new("horizontal_fov_deg", format!("must be in (0, 180), got {fov}")));
        }
        positive("baseline_m", self.baseline_m)?;
        finite("mount_frd_m", &self.mount_frd_m)?;
        non_negative("noise_std", self.noise_std)?;
        within("exposure_time_s", self.exposure_time_s, 0.0, MAX_EXPOSURE_S)?;
        if !(1..=MAX_BLUR_SAMPLES).contains(&self.blur_samples) {
            return Err(InvalidParam::new(
                "blur_samples",
                format!("must be in 1..={MAX_BLUR_SAMPLES}, got {}", self.blur_samples),
            ));
        }
        within("exposure_gain_std", self.exposure_gain_std, 0.0, 1.0)?;
        within("lr_gain_mismatch", self.lr_gain_mismatch, -0.5, 0.5)
    }

    /// The pinhole model of both (rectified) cameras.
    pub fn intrinsics(&self) -> Intrinsics {
        let half_fov = (self.horizontal_fov_deg / 2.0).to_radians();
        Intrinsics {
            focal_px: f64::from(self.width_px) / 2.0 / half_fov.tan(),
            cx_px: (f64::from(self.width_px) - 1.0) / 2.0,
            cy_px: (f64::from(self.height_px) - 1.0) / 2.0,
            baseline_m: self.baseline_m,
        }
    }
}

/// Checks that `value` is a number in `[lo, hi]`.
fn within(field: &str, value: f64, lo: f64, hi: f64) -> Result<(), InvalidParam> {
    if (lo..=hi).contains(&value) {
        Ok(())
    } else {
        Err(InvalidParam::new(field, format!("must be in [{lo}, {hi}], got {value}")))
    }
}

/// The rectified pinhole model shared by both cameras: square pixels, no distortion, pixel
/// centres at integer coordinates, and the right camera `baseline_m` to the left camera's right
/// (so a point at depth `Z` appears `focal_px·baseline_m/Z` px further left in the right image).
/// These are the numbers the stereo actor's `rectified` geometry wants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Intrinsics {
    /// Focal length (px).
    pub focal_px: f64,
    /// Principal point, column (px).
    pub cx_px: f64,
    /// Principal point, row (px).
    pub cy_px: f64,
    /// Distance between the optical centres (m).
    pub baseline_m: f64,
}

impl Intrinsics {
    /// Disparity of a point at depth `depth_m` (px).
    pub fn disparity_px(&self, depth_m: f64) -> f64 {
        self.focal_px * self.baseline_m / depth_m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zed_like_defaults() {
        let p = StereoCameraParams::default();
        p.validate().unwrap();
        let k = p.intrinsics();
        assert!((k.focal_px - 320.0 / 55f64.to_radians().tan()).abs() < 1e-9);
        assert_eq!((k.cx_px, k.cy_px), (319.5, 239.5));
        assert!((k.disparity_px(3.0) - k.focal_px * 0.04).abs() < 1e-9);
    }

    #[test]
    fn bad_params_name_their_field() {
        let bad = |p: StereoCameraParams| p.validate().unwrap_err().field;
        let d = StereoCameraParams::default;
        assert_eq!(bad(StereoCameraParams { width_px: 0, ..d() }), "width_px");
        assert_eq!(bad(StereoCameraParams { height_px: 100_000, ..d() }), "height_px");
        assert_eq!(bad(StereoCameraParams { horizontal_fov_deg: 180.0, ..d() }), "horizontal_fov_deg");
        assert_eq!(bad(StereoCameraParams { baseline_m: 0.0, ..d() }), "baseline_m");
        assert_eq!(bad(StereoCameraParams { mount_frd_m: [f64::NAN, 0.0, 0.0], ..d() }), "mount_frd_m");
        assert_eq!(bad(StereoCameraParams { noise_std: -1.0, ..d() }), "noise_std");
        for exposure_time_s in [-0.001, 0.2, f64::NAN] {
            assert_eq!(bad(StereoCameraParams { exposure_time_s, ..d() }), "exposure_time_s");
        }
        for blur_samples in [0, 65] {
            assert_eq!(bad(StereoCameraParams { blur_samples, ..d() }), "blur_samples");
        }
        for exposure_gain_std in [-0.1, 1.5, f64::INFINITY] {
            assert_eq!(bad(StereoCameraParams { exposure_gain_std, ..d() }), "exposure_gain_std");
        }
        for lr_gain_mismatch in [-0.6, 0.6, f64::NAN] {
            assert_eq!(bad(StereoCameraParams { lr_gain_mismatch, ..d() }), "lr_gain_mismatch");
        }
    }
}
