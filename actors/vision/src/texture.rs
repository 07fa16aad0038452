//! Invalidating disparities where the image has no texture to match.
//!
//! Semi-global matching fills a textureless patch with disparities propagated from its
//! borders; a plain wall then reads as whatever surrounds it (the thesis's failure, §4.2.3,
//! seen from the other side). A pixel whose neighbourhood has a mean horizontal gradient below
//! a threshold gets no disparity, so the grid reports the patch as invalid, not as free.

use opencv::core::{
    BORDER_REPLICATE, CMP_LT, CV_16S, CV_32F, Mat, MatTraitConst, MatTraitConstManual, Point, Scalar, Size,
};
use opencv::imgproc;
use serde::{Deserialize, Serialize};

use crate::disparity_map::DisparityMap;
use crate::error::{CvContext, VisionError};

/// When a pixel counts as textureless.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TextureParams {
    /// Smallest mean |∂I/∂x| over the window (grey levels per px) for a pixel to keep its
    /// disparity; 0 disables the check.
    pub min_gradient: f32,
    /// Side of the square window the gradient is averaged over (px, odd).
    pub window_px: u32,
}

impl Default for TextureParams {
    /// ¼ grey level per px over 15×15 px: a uniformly painted patch loses its disparities,
    /// while the faintly textured surfaces of the Middlebury scenes, which SGBM matches well,
    /// keep theirs (at 1 grey level per px teddy's bad-2 rose from 22 % to 33 %). Noisy
    /// textureless surfaces pass this check; SGBM's uniqueness and speckle checks catch most.
    fn default() -> Self {
        TextureParams { min_gradient: 0.25, window_px: 15 }
    }
}

/// Applies [`TextureParams`] to disparity maps; keeps its buffers across frames.
pub struct TextureFilter {
    params: TextureParams,
    gradient: Mat,
    magnitude: Mat,
    mean: Mat,
    /// 255 where textureless, else 0.
    mask: Mat,
}

impl TextureFilter {
    /// Checks the parameters; `None` when the check is disabled.
    pub fn new(params: &TextureParams) -> Result<Option<TextureFilter>, VisionError> {
        if !(params.min_gradient.is_finite() && params.min_gradient >= 0.0) {
            return Err(VisionError::Params(format!(
                "texture min_gradient {} must be ≥ 0",
                params.min_gradient
            )));
        }
        if params.window_px.is_multiple_of(2) || !(3..=31).contains(&params.window_px) {
            return Err(VisionError::Params(format!(
                "texture window_px {} must be odd in 3..=31",
                params.window_px
            )));
        }
        Ok((params.min_gradient > 0.0).then(|| TextureFilter {
            params: params.clone(),
            gradient: Mat::default(),
            magnitude: Mat::default(),
            mean: Mat::default(),
            mask: Mat::default(),
        }))
    }

    /// Marks invalid every pixel of `disparity` whose neighbourhood in `image` (the matched
    /// left image, same size) is textureless.
    pub fn apply(&mut self, image: &Mat, disparity: &mut DisparityMap) -> Result<(), VisionError> {
        if (image.cols() as usize, image.rows() as usize) != (disparity.width, disparity.height) {
            return Err(VisionError::Input("texture image and disparity differ in size".into()));
        }
        for (d, &textureless) in disparity.values.iter_mut().zip(self.textureless(image)?) {
            if textureless != 0 {
                *d = f32::NAN;
            }
        }
        Ok(())
    }

    /// Per pixel of `image` (row-major, continuous): non-zero where its neighbourhood is
    /// textureless. Valid until the next call.
    pub fn textureless(&mut self, image: &Mat) -> Result<&[u8], VisionError> {
        // Central difference I(x+1) − I(x−1), halved to grey levels per pixel.
        imgproc::sobel(image, &mut self.gradient, CV_16S, 1, 0, 1, 0.5, 0.0, BORDER_REPLICATE)
            .cv("texture gradient")?;
        opencv::core::convert_scale_abs(&self.gradient, &mut self.magnitude, 1.0, 0.0)
            .cv("texture magnitude")?;
        let w = self.params.window_px as i32;
        imgproc::box_filter(
            &self.magnitude,
            &mut self.mean,
            CV_32F,
            Size::new(w, w),
            Point::new(-1, -1),
            true,
            BORDER_REPLICATE,
        )
        .cv("texture mean")?;
        opencv::core::compare(
            &self.mean,
            &Scalar::all(f64::from(self.params.min_gradient)),
            &mut self.mask,
            CMP_LT,
        )
        .cv("texture threshold")?;
        self.mask.data_bytes().cv("texture mask")
    }
}
