//! Disparity accuracy against ground truth, Middlebury style: bad-1/bad-2 (% of pixels with
//! known ground truth whose disparity is off by more than 1 or 2 px, pixels without a
//! disparity counted as bad), the same outside the left band no matcher can fill, end-point
//! error and density.

use std::path::Path;

use opencv::core::{CV_32F, Mat, MatTraitConst, MatTraitConstManual};

use crate::disparity_map::DisparityMap;
use crate::error::{CvContext, VisionError};
use crate::image::load_unchanged;

/// Ground-truth disparity (px); `NaN` where unknown.
#[derive(Clone, Debug, PartialEq)]
pub struct GroundTruth {
    pub width: usize,
    pub height: usize,
    pub values: Vec<f32>,
}

impl GroundTruth {
    /// Reads an 8- or 16-bit single-channel image where 0 is unknown and every other value is
    /// `disparity · scale` (Middlebury 2003/2005/2006: scale 4 at full size, 2 at half size…).
    pub fn load(path: &Path, scale: f32) -> Result<GroundTruth, VisionError> {
        let image = load_unchanged(path)?;
        GroundTruth::from_scaled(&image, scale)
            .map_err(|e| VisionError::BadFile { path: path.to_owned(), what: e.to_string() })
    }

    /// As [`GroundTruth::load`], from an image already in memory.
    pub fn from_scaled(image: &Mat, scale: f32) -> Result<GroundTruth, VisionError> {
        if !(scale.is_finite() && scale > 0.0) {
            return Err(VisionError::Params(format!("ground-truth scale {scale} must be positive")));
        }
        if image.channels() != 1 {
            return Err(VisionError::Input(format!(
                "ground truth must have one channel, has {}",
                image.channels()
            )));
        }
        let mut values = Mat::default();
        image.convert_to_def(&mut values, CV_32F).cv("ground truth to float")?;
        let values = values.data_typed::<f32>().cv("ground truth pixels")?;
        let values = values.iter().map(|&v| if v > 0.0 { v / scale } else { f32::NAN }).collect();
        Ok(GroundTruth { width: image.cols() as usize, height: image.rows() as usize, values })
    }
}

impl GroundTruth {
    /// This (left-view) ground truth with occluded pixels made unknown: a pixel whose
    /// disparity `d` does not land within `tolerance_px` of the same disparity in the right
    /// view's ground truth `right` at `x − d` is seen by the left camera only. Middlebury's
    /// "non-occluded" masks are built the same way.
    pub fn non_occluded(&self, right: &GroundTruth, tolerance_px: f32) -> Result<GroundTruth, VisionError> {
        if (self.width, self.height) != (right.width, right.height) {
            return Err(VisionError::Input(format!(
                "left ground truth is {}×{} but right is {}×{}",
                self.width, self.height, right.width, right.height
            )));
        }
        let mut values = self.values.clone();
        for (i, v) in values.iter_mut().enumerate() {
            if v.is_nan() {
                continue;
            }
            let (x, y) = ((i % self.width) as f32, i / self.width);
            let xr = (x - *v).round();
            let seen = xr >= 0.0 && {
                let r = right.values[y * self.width + xr as usize];
                !r.is_nan() && (r - *v).abs() <= tolerance_px
            };
            if !seen {
                *v = f32::NAN;
            }
        }
        Ok(GroundTruth { width: self.width, height: self.height, values })
    }
}

/// How good a disparity map is against ground truth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DisparityScores {
    /// % of known-ground-truth pixels off by more than 1 px or without a disparity.
    pub bad1_pct: f64,
    /// % of known-ground-truth pixels off by more than 2 px or without a disparity.
    pub bad2_pct: f64,
    /// `bad2_pct` over the pixels right of the left band (width = the disparity search
    /// range), which a left-referenced matcher cannot fill.
    pub bad2_outside_band_pct: f64,
    /// Mean |disparity − ground truth| over pixels with both (px).
    pub epe_px: f64,
    /// % of known-ground-truth pixels that have a disparity.
    pub density_pct: f64,
    /// Pixels with known ground truth.
    pub known_px: usize,
}

/// Scores `disparity` against `truth`; `band_px` is the width of the left band left out of
/// [`DisparityScores::bad2_outside_band_pct`].
pub fn score(
    disparity: &DisparityMap,
    truth: &GroundTruth,
    band_px: usize,
) -> Result<DisparityScores, VisionError> {
    if (disparity.width, disparity.height) != (truth.width, truth.height) {
        return Err(VisionError::Input(format!(
            "disparity is {}×{} but ground truth is {}×{}",
            disparity.width, disparity.height, truth.width, truth.height
        )));
    }
    let (mut known, mut bad1, mut bad2, mut known_out, mut bad2_out, mut valid, mut err_sum) =
        (0usize, 0usize, 0usize, 0usize, 0usize, 0usize, 0f64);
    for (i, (&d, &gt)) in disparity.values.iter().zip(&truth.values).enumerate() {
        if gt.is_nan() {
            continue;
        }
        let outside = i % truth.width >= band_px;
        known += 1;
        known_out += usize::from(outside);
        let error = if d.is_nan() {
            f32::INFINITY
        } else {
            valid += 1;
            let e = (d - gt).abs();
            err_sum += f64::from(e);
            e
        };
        bad1 += usize::from(error > 1.0);
        bad2 += usize::from(error > 2.0);
        bad2_out += usize::from(outside && error > 2.0);
    }
    if known == 0 {
        return Err(VisionError::Input("ground truth has no known pixel".into()));
    }
    let pct = |n: usize, of: usize| 100.0 * n as f64 / of.max(1) as f64;
    Ok(DisparityScores {
        bad1_pct: pct(bad1, known),
        bad2_pct: pct(bad2, known),
        bad2_outside_band_pct: pct(bad2_out, known_out),
        epe_px: if valid > 0 { err_sum / valid as f64 } else { f64::NAN },
        density_pct: pct(valid, known),
        known_px: known,
    })
}
