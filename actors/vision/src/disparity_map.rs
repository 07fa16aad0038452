//! A disparity image in pixels, with invalid pixels kept apart from every real value.

use opencv::core::{Mat, MatTraitConst, MatTraitConstManual};

use crate::error::{CvContext, VisionError};

/// Disparity of the left image (px), row-major; `NaN` marks a pixel without a disparity
/// (occluded, textureless, outside the search range, rejected by a consistency check).
/// Read it through [`DisparityMap::get`], which turns the marker into `None`.
#[derive(Clone, Debug, PartialEq)]
pub struct DisparityMap {
    pub width: usize,
    pub height: usize,
    pub values: Vec<f32>,
}

impl DisparityMap {
    /// Converts OpenCV's fixed-point output (`CV_16S`, 1/16 px; `(min_disparity − 1)·16`
    /// marks invalid pixels) into pixels with `NaN` for invalid.
    pub fn from_fixed_point(raw: &Mat, min_disparity: i32) -> Result<DisparityMap, VisionError> {
        let copy;
        let raw = if raw.is_continuous() {
            raw
        } else {
            copy = raw.try_clone().cv("disparity copy")?;
            &copy
        };
        let data = raw.data_typed::<i16>().cv("disparity pixels")?;
        let invalid_below = min_disparity * 16;
        let values = data
            .iter()
            .map(|&v| if i32::from(v) < invalid_below { f32::NAN } else { f32::from(v) / 16.0 })
            .collect();
        Ok(DisparityMap { width: raw.cols() as usize, height: raw.rows() as usize, values })
    }

    /// The disparity at column `x`, row `y` (px), `None` where invalid or outside the image.
    pub fn get(&self, x: usize, y: usize) -> Option<f32> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let d = self.values[y * self.width + x];
        (!d.is_nan()).then_some(d)
    }

    /// The disparity of the `width`×`height` image this map was computed on after shrinking it
    /// `factor_x` times along rows and `factor_y` times across them: each pixel spreads over the
    /// block it stood for, its disparity multiplied by `factor_x` (px of the larger image).
    /// For scoring a shrunken match against full-size ground truth.
    pub fn upscaled(&self, factor_x: usize, factor_y: usize, width: usize, height: usize) -> DisparityMap {
        let (fx, fy) = (factor_x.max(1), factor_y.max(1));
        let mut values = Vec::with_capacity(width * height);
        for y in 0..height {
            let sy = (y / fy).min(self.height.saturating_sub(1));
            for x in 0..width {
                let sx = (x / fx).min(self.width.saturating_sub(1));
                values.push(self.values.get(sy * self.width + sx).map_or(f32::NAN, |&d| d * fx as f32));
            }
        }
        DisparityMap { width, height, values }
    }

    /// Share of pixels with a disparity, 0..1.
    pub fn density(&self) -> f64 {
        let valid = self.values.iter().filter(|d| !d.is_nan()).count();
        valid as f64 / self.values.len().max(1) as f64
    }
}
