//! Depth as a picture for people: a colour PNG with a perceptually uniform colour map
//! (viridis), invalid pixels black.
//!
//! Colour follows inverse depth (proportional to disparity) between the range's ends, so the
//! near field, where obstacles matter and stereo resolves depth best, gets most of the colour
//! scale: yellow at `near_m` and nearer, dark purple at `far_m` and beyond. Viridis never
//! produces black (its darkest entry is RGB 68, 1, 84), so black means "no depth".

use std::path::Path;

use opencv::core::{CV_8UC1, Mat, MatTraitConst, MatTraitManual, Vec3b, Vector};
use opencv::{imgcodecs, imgproc};

use crate::depth::DepthMap;
use crate::error::{CvContext, VisionError};

/// The depths the colour scale spans (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthRange {
    /// Depths at or nearer than this are the top colour (yellow).
    pub near_m: f32,
    /// Depths at or beyond this are the bottom colour (dark purple).
    pub far_m: f32,
}

impl Default for DepthRange {
    /// 0.5–20 m: the obstacle sectors' range (0.3–20 m) without the near end, where few
    /// stereo rigs still match.
    fn default() -> Self {
        DepthRange { near_m: 0.5, far_m: 20.0 }
    }
}

impl DepthRange {
    /// Rejects a range that is empty, reversed or not positive.
    pub fn checked(self) -> Result<DepthRange, VisionError> {
        if !(self.near_m.is_finite()
            && self.far_m.is_finite()
            && 0.0 < self.near_m
            && self.near_m < self.far_m)
        {
            return Err(VisionError::Params(format!(
                "depth colour range {}..{} m must satisfy 0 < near < far",
                self.near_m, self.far_m
            )));
        }
        Ok(self)
    }

    /// Position of depth `z_m` on the colour scale: 255 at `near_m` and nearer, 0 at `far_m`
    /// and beyond, linear in 1/z between.
    pub fn level(&self, z_m: f32) -> u8 {
        let (lo, hi) = (1.0 / self.far_m, 1.0 / self.near_m);
        let t = ((1.0 / z_m - lo) / (hi - lo)).clamp(0.0, 1.0);
        (t * 255.0).round() as u8
    }
}

/// `depth` coloured with viridis over `range` (8-bit BGR, OpenCV's channel order), invalid
/// pixels black.
pub fn colourise(depth: &DepthMap, range: DepthRange) -> Result<Mat, VisionError> {
    let range = range.checked()?;
    let too_large =
        || VisionError::Input(format!("a {}×{} depth map is too large", depth.width, depth.height));
    let rows = i32::try_from(depth.height).map_err(|_| too_large())?;
    let cols = i32::try_from(depth.width).map_err(|_| too_large())?;
    if depth.values.len() != depth.width * depth.height || depth.values.is_empty() {
        return Err(VisionError::Input(format!(
            "a {}×{} depth map needs {} values, has {}",
            depth.width,
            depth.height,
            depth.width * depth.height,
            depth.values.len()
        )));
    }
    let mut levels =
        Mat::new_rows_cols_with_default(rows, cols, CV_8UC1, 0.into()).cv("depth levels buffer")?;
    for (level, &z) in levels.data_typed_mut::<u8>().cv("depth levels")?.iter_mut().zip(&depth.values) {
        *level = if z.is_nan() { 0 } else { range.level(z) };
    }
    let mut colour = Mat::default();
    imgproc::apply_color_map(&levels, &mut colour, imgproc::COLORMAP_VIRIDIS).cv("viridis colour map")?;
    if !colour.is_continuous() {
        colour = colour.try_clone().cv("depth colour copy")?;
    }
    for (pixel, &z) in colour.data_typed_mut::<Vec3b>().cv("depth colours")?.iter_mut().zip(&depth.values) {
        if z.is_nan() {
            *pixel = Vec3b::from([0, 0, 0]);
        }
    }
    Ok(colour)
}

/// Writes [`colourise`]`(depth, range)` to `path` as PNG.
pub fn write_depth_png(depth: &DepthMap, range: DepthRange, path: &Path) -> Result<(), VisionError> {
    if !path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("png")) {
        return Err(VisionError::Params(format!("{}: the depth picture must end in .png", path.display())));
    }
    let image = colourise(depth, range)?;
    let name = path.to_string_lossy();
    let written = imgcodecs::imwrite(&*name, &image, &Vector::new()).cv_with(|| format!("writing {name}"))?;
    if !written {
        return Err(VisionError::BadFile {
            path: path.to_owned(),
            what: "could not be written as PNG".into(),
        });
    }
    Ok(())
}
