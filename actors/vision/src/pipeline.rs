//! Frame → depth grid: rectify, optionally shrink, match, convert to depth, summarise. The
//! pure core the stereo actor, the benchmarks and the CLI drive.

use std::path::{Path, PathBuf};

use kestrel_proto::messages::{DepthGrid, StereoFrame};
use opencv::core::{Mat, Size};
use opencv::imgproc;
use serde::{Deserialize, Serialize};

use crate::calibration::StereoCalibration;
use crate::depth::{DepthMap, StereoGeometry};
use crate::disparity_map::DisparityMap;
use crate::error::{CvContext, VisionError};
use crate::grid::{GridParams, depth_grid};
use crate::image::gray_mat;
use crate::matcher::{Matcher, MatcherParams};
use crate::rectify::Rectifier;
use crate::texture::{TextureFilter, TextureParams};

/// How frames are processed (the `pipeline` table of the stereo actor's parameters).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PipelineParams {
    pub matcher: MatcherParams,
    /// Shrink the rectified images by this integer factor before matching (1 = full size);
    /// the disparity range shrinks with them (rounded up to a multiple of 16). 2 makes SGBM
    /// ~6× faster at half the depth resolution, enough for the avoider's 3×3 grid.
    pub downscale: u32,
    /// Pixels without texture lose their disparity.
    pub texture: TextureParams,
    pub grid: GridParams,
}

impl Default for PipelineParams {
    fn default() -> Self {
        PipelineParams {
            matcher: MatcherParams::default(),
            downscale: 1,
            texture: TextureParams::default(),
            grid: GridParams::default(),
        }
    }
}

/// Where the pipeline's geometry comes from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Geometry {
    /// Raw frames from a calibrated camera: rectified with the calibration file at this path
    /// (relative paths resolve against the config's directory).
    Calibration(PathBuf),
    /// Frames that are already rectified (simulator, a camera that rectifies on board).
    Rectified(StereoGeometry),
}

/// The working state of frame → grid; reuse it across frames.
pub struct StereoPipeline {
    rectifier: Option<Rectifier>,
    /// Geometry of the images the matcher sees (after any downscale).
    geometry: StereoGeometry,
    downscale: u32,
    matcher: Matcher,
    texture: Option<TextureFilter>,
    grid: GridParams,
    rectified: (Mat, Mat),
    small: (Mat, Mat),
}

impl StereoPipeline {
    /// Builds the pipeline, loading the calibration (relative to `base_dir`) if there is one.
    pub fn new(
        geometry: &Geometry,
        params: &PipelineParams,
        base_dir: &Path,
    ) -> Result<StereoPipeline, VisionError> {
        let (rectifier, geometry) = match geometry {
            Geometry::Calibration(path) => {
                let calibration = StereoCalibration::load(&base_dir.join(path))?;
                (Some(Rectifier::new(&calibration)?), StereoGeometry::from_calibration(&calibration)?)
            }
            Geometry::Rectified(g) => (None, g.checked()?),
        };
        StereoPipeline::with_parts(rectifier, geometry, params)
    }

    /// Builds the pipeline from an already loaded calibration.
    pub fn calibrated(
        calibration: &StereoCalibration,
        params: &PipelineParams,
    ) -> Result<StereoPipeline, VisionError> {
        StereoPipeline::with_parts(
            Some(Rectifier::new(calibration)?),
            StereoGeometry::from_calibration(calibration)?,
            params,
        )
    }

    fn with_parts(
        rectifier: Option<Rectifier>,
        geometry: StereoGeometry,
        params: &PipelineParams,
    ) -> Result<StereoPipeline, VisionError> {
        params.grid.check()?;
        if !(1..=8).contains(&params.downscale) {
            return Err(VisionError::Params(format!("downscale {} must be in 1..=8", params.downscale)));
        }
        let range = params.matcher.num_disparities();
        let small_range = (range + 16 * params.downscale as i32 - 1) / (16 * params.downscale as i32) * 16;
        let matcher = Matcher::new(&params.matcher.with_num_disparities(small_range.max(16)))?;
        Ok(StereoPipeline {
            rectifier,
            geometry: geometry.downscaled(params.downscale),
            downscale: params.downscale,
            matcher,
            texture: TextureFilter::new(&params.texture)?,
            grid: params.grid.clone(),
            rectified: (Mat::default(), Mat::default()),
            small: (Mat::default(), Mat::default()),
        })
    }

    /// Geometry of the disparity and depth images this pipeline produces.
    pub fn geometry(&self) -> &StereoGeometry {
        &self.geometry
    }

    /// The depth grid of `frame`.
    pub fn process(&mut self, frame: &StereoFrame) -> Result<DepthGrid, VisionError> {
        if !frame.has_pixels() {
            return Err(VisionError::Input(format!(
                "frame {} carries no pixels (read back from a log?)",
                frame.sequence
            )));
        }
        let left = gray_mat(frame.left(), frame.width, frame.height)?;
        let right = gray_mat(frame.right(), frame.width, frame.height)?;
        let depth = self.depth(&left, &right)?;
        Ok(depth_grid(&depth, &self.geometry, &self.grid, frame.time, frame.sequence))
    }

    /// Depth of a raw grey pair (m).
    pub fn depth(&mut self, left: &Mat, right: &Mat) -> Result<DepthMap, VisionError> {
        let disparity = self.disparity(left, right)?;
        Ok(DepthMap::from_disparity(&disparity, &self.geometry))
    }

    /// Disparity of a raw grey pair (px, at the downscaled size).
    pub fn disparity(&mut self, left: &Mat, right: &Mat) -> Result<DisparityMap, VisionError> {
        let (mut left, mut right) = (left, right);
        if let Some(rectifier) = &self.rectifier {
            let (l, r) = &mut self.rectified;
            rectifier.rectify_into(left, right, l, r)?;
            (left, right) = (&self.rectified.0, &self.rectified.1);
        }
        if self.downscale > 1 {
            let f = 1.0 / f64::from(self.downscale);
            let (l, r) = &mut self.small;
            imgproc::resize(left, l, Size::default(), f, f, imgproc::INTER_AREA)
                .cv("shrinking the left image")?;
            imgproc::resize(right, r, Size::default(), f, f, imgproc::INTER_AREA)
                .cv("shrinking the right image")?;
            (left, right) = (&self.small.0, &self.small.1);
        }
        let mut disparity = self.matcher.compute(left, right)?;
        if let Some(texture) = &mut self.texture {
            texture.apply(left, &mut disparity)?;
        }
        Ok(disparity)
    }
}
