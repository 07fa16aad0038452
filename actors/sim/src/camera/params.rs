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
    /// Seed of the surface texture and the image noise.
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
            seed: 1,
        }
    }
}

/// Largest image side the renderer accepts (px).
const MAX_SIDE_PX: u32 = 8192;

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
        non_negative("noise_std", self.noise_std)
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
    }
}
