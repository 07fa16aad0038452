//! Depth from disparity (thesis eq. 1.30): `Z = B·f / (d + doffs)`, from the calibration's `Q`.
//!
//! Frame: the rectified left camera (x right, y down, z along the optical axis). A pixel
//! without a disparity stays without a depth; it never becomes 0 m or ∞.

use serde::{Deserialize, Serialize};

use crate::calibration::StereoCalibration;
use crate::disparity_map::DisparityMap;
use crate::error::VisionError;

/// The rectified left camera's pinhole model and the stereo baseline.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StereoGeometry {
    /// Focal length (px).
    pub focal_px: f64,
    /// Principal point, column (px).
    pub cx_px: f64,
    /// Principal point, row (px).
    pub cy_px: f64,
    /// Distance between the two optical centres (m).
    pub baseline_m: f64,
    /// Right principal point column minus the left's (px); 0 when rectified with zero
    /// disparity at infinity (Middlebury's `doffs`).
    #[serde(default)]
    pub doffs_px: f64,
    /// Multiplies every depth (thesis §3.2.5); 1 without a measured correction.
    #[serde(default = "one")]
    pub depth_scale: f64,
}

fn one() -> f64 {
    1.0
}

impl StereoGeometry {
    /// Reads the geometry off `Q`: `f = Q₂₃`, `cx = −Q₀₃`, `cy = −Q₁₃`, `B = 1/Q₃₂`,
    /// `doffs = Q₃₃/Q₃₂`.
    pub fn from_calibration(c: &StereoCalibration) -> Result<StereoGeometry, VisionError> {
        let q = &c.q;
        StereoGeometry {
            focal_px: q[2][3],
            cx_px: -q[0][3],
            cy_px: -q[1][3],
            baseline_m: 1.0 / q[3][2],
            doffs_px: q[3][3] / q[3][2],
            depth_scale: c.depth_scale,
        }
        .checked()
    }

    /// Rejects a geometry that cannot give depths.
    pub fn checked(self) -> Result<StereoGeometry, VisionError> {
        let finite =
            [self.focal_px, self.cx_px, self.cy_px, self.baseline_m, self.doffs_px, self.depth_scale];
        if !finite.iter().all(|v| v.is_finite()) || self.focal_px <= 0.0 || self.depth_scale <= 0.0 {
            return Err(VisionError::Params(format!("unusable stereo geometry {self:?}")));
        }
        if self.baseline_m <= 0.0 {
            return Err(VisionError::Params(format!(
                "baseline {} m: the right camera must be right of the left one",
                self.baseline_m
            )));
        }
        Ok(self)
    }

    /// The same camera for images shrunk by `factor` (focal length and pixel positions scale,
    /// the baseline does not).
    pub fn downscaled(&self, factor: u32) -> StereoGeometry {
        let f = f64::from(factor.max(1));
        StereoGeometry {
            focal_px: self.focal_px / f,
            cx_px: (self.cx_px + 0.5) / f - 0.5,
            cy_px: (self.cy_px + 0.5) / f - 0.5,
            doffs_px: self.doffs_px / f,
            ..*self
        }
    }

    /// The same camera for images whose rows were merged `factor` to one (only the row
    /// coordinate scales: the focal length, the baseline and disparities act along rows).
    pub fn rows_downscaled(&self, factor: u32) -> StereoGeometry {
        let f = f64::from(factor.max(1));
        StereoGeometry { cy_px: (self.cy_px + 0.5) / f - 0.5, ..*self }
    }

    /// Depth along the optical axis (m) of a pixel with disparity `d_px`; `None` for no
    /// disparity or one at or beyond infinity.
    pub fn depth_m(&self, d_px: f32) -> Option<f32> {
        let denominator = f64::from(d_px) + self.doffs_px;
        (denominator > 0.0).then(|| (self.depth_scale * self.focal_px * self.baseline_m / denominator) as f32)
    }
}

/// Depth of each pixel of the left rectified image (m); `NaN` where there is none. Read it
/// through [`DepthMap::get`].
#[derive(Clone, Debug, PartialEq)]
pub struct DepthMap {
    pub width: usize,
    pub height: usize,
    pub values: Vec<f32>,
}

impl DepthMap {
    /// Converts every disparity with `geometry`; invalid stays invalid.
    pub fn from_disparity(disparity: &DisparityMap, geometry: &StereoGeometry) -> DepthMap {
        let values = disparity
            .values
            .iter()
            .map(|&d| if d.is_nan() { f32::NAN } else { geometry.depth_m(d).unwrap_or(f32::NAN) });
        DepthMap { width: disparity.width, height: disparity.height, values: values.collect() }
    }

    /// Depth at column `x`, row `y` (m), `None` where there is none or outside the image.
    pub fn get(&self, x: usize, y: usize) -> Option<f32> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let z = self.values[y * self.width + x];
        (!z.is_nan()).then_some(z)
    }
}

/// The depth (m) of every fixed-point disparity (1/16 px) a matcher searching
/// `min_disparity .. min_disparity + num_disparities` gives, looked up instead of divided, for
/// [`crate::DepthGridder::grid_fixed_point`]. Each value is [`StereoGeometry::depth_m`] of
/// [`DisparityMap::from_fixed_point`]'s disparity, so the depth is bit for bit
/// [`DepthMap::from_disparity`]'s.
///
/// A pixel's *code* indexes the table: 0 for no disparity (the matcher's invalid marker,
/// anything below the range, or no texture), `1 + raw − min_disparity·16` within the range,
/// and one past the table for a value beyond it (which no matcher gives).
pub struct FixedPointDepth {
    /// The raw value of code 1: `min_disparity · 16`.
    first: i32,
    depths: Vec<f32>,
}

impl FixedPointDepth {
    pub fn new(geometry: &StereoGeometry, min_disparity: i32, num_disparities: i32) -> FixedPointDepth {
        let first = min_disparity * 16;
        let depths = (first..=first + num_disparities.max(0) * 16)
            .map(|raw| geometry.depth_m(raw as f32 / 16.0).unwrap_or(f32::NAN))
            .collect();
        FixedPointDepth { first, depths }
    }

    /// How many codes there are (no disparity, the range, beyond it).
    pub fn codes(&self) -> usize {
        self.depths.len() + 2
    }

    /// The code of raw disparity `raw` at a pixel whose texture flag is `textureless`; in 32
    /// bits and without branches, so a row of them is computed in vector lanes.
    #[inline(always)]
    pub fn code(&self, raw: i16, textureless: u8) -> u32 {
        // Wrapping only drops test builds' overflow checks (which kept a row out of vector
        // lanes): a raw value is an i16 and the first code's a matcher's minimum disparity
        // times 16, far inside i32.
        let offset = i32::from(raw).wrapping_sub(self.first);
        let beyond = self.depths.len() as i32 + 1;
        let code = offset.wrapping_add(1).clamp(0, beyond);
        if textureless != 0 { 0 } else { code as u32 }
    }

    /// The depth of `code` (m, `NaN` for none or at or beyond infinity); `None` beyond the table.
    pub fn depth_of_code(&self, code: usize) -> Option<f32> {
        match code {
            0 => Some(f32::NAN),
            c => self.depths.get(c - 1).copied(),
        }
    }
}
