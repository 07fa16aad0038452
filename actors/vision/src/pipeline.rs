//! Frame → depth grid: rectify, optionally shrink, match, convert to depth, summarise. The
//! pure core the stereo actor, the benchmarks and the CLI drive.
//!
//! It times its own stages (monotonic clock, for `kestrel stereo`'s report); the timings
//! never influence the results.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use kestrel_proto::Time;
use kestrel_proto::messages::{DepthGrid, StereoFrame};
use opencv::core::{Mat, MatTraitConst, MatTraitConstManual, Size};
use opencv::imgproc;
use serde::{Deserialize, Serialize};

use crate::calibration::StereoCalibration;
use crate::depth::{DepthMap, FixedPointDepth, StereoGeometry};
use crate::disparity_map::DisparityMap;
use crate::error::{CvContext, VisionError};
use crate::grid::{DepthGridder, GridParams};
use crate::image::copy_gray_into;
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
    /// Then also merge this many rows into one (averaging them) before matching, 1..=4.
    /// Disparity runs along rows, so depth resolution is untouched while matching costs 1/n;
    /// the grid sees n-times fewer, vertically averaged, pixels.
    pub row_downscale: u32,
    /// Pixels without texture lose their disparity.
    pub texture: TextureParams,
    pub grid: GridParams,
}

impl Default for PipelineParams {
    fn default() -> Self {
        PipelineParams {
            matcher: MatcherParams::default(),
            downscale: 1,
            row_downscale: 1,
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

/// How long each stage of the last frame took.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StageTimes {
    /// Undistortion and rectification (`remap`), and any downscale.
    pub rectify: Duration,
    /// Disparity search and the texture check.
    pub matching: Duration,
    /// Disparity → depth; zero on the frame → grid path ([`StereoPipeline::grid`]), whose grid
    /// stage reads the matcher's output directly.
    pub depth: Duration,
    /// Depth (or, frame → grid, the matcher's output) → grid regions and sectors.
    pub grid: Duration,
}

/// The working state of frame → grid; reuse it across frames.
pub struct StereoPipeline {
    rectifier: Option<Rectifier>,
    /// Geometry of the images the matcher sees (after any downscale).
    geometry: StereoGeometry,
    downscale: u32,
    row_downscale: u32,
    matcher: Matcher,
    texture: Option<TextureFilter>,
    gridder: DepthGridder,
    /// The depth of each of the matcher's raw values, for [`StereoPipeline::grid`].
    fixed_point_depth: FixedPointDepth,
    times: StageTimes,
    /// [`StereoPipeline::process`]'s copy of the frame, kept so a frame allocates none.
    input: (Mat, Mat),
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
        if !(1..=4).contains(&params.row_downscale) {
            return Err(VisionError::Params(format!(
                "row_downscale {} must be in 1..=4",
                params.row_downscale
            )));
        }
        let range = params.matcher.num_disparities();
        let small_range = (range + 16 * params.downscale as i32 - 1) / (16 * params.downscale as i32) * 16;
        let matcher = Matcher::new(&params.matcher.with_num_disparities(small_range.max(16)))?;
        let geometry = geometry.downscaled(params.downscale).rows_downscaled(params.row_downscale);
        Ok(StereoPipeline {
            rectifier,
            geometry,
            downscale: params.downscale,
            row_downscale: params.row_downscale,
            fixed_point_depth: FixedPointDepth::new(
                &geometry,
                matcher.min_disparity(),
                matcher.num_disparities(),
            ),
            matcher,
            texture: TextureFilter::new(&params.texture)?,
            gridder: DepthGridder::new(&params.grid, &geometry),
            times: StageTimes::default(),
            input: (Mat::default(), Mat::default()),
            rectified: (Mat::default(), Mat::default()),
            small: (Mat::default(), Mat::default()),
        })
    }

    /// Geometry of the disparity and depth images this pipeline produces.
    pub fn geometry(&self) -> &StereoGeometry {
        &self.geometry
    }

    /// How long each stage of the last frame took.
    pub fn times(&self) -> StageTimes {
        self.times
    }

    /// The depth grid of `frame`.
    pub fn process(&mut self, frame: &StereoFrame) -> Result<DepthGrid, VisionError> {
        if !frame.has_pixels() {
            return Err(VisionError::Input(format!(
                "frame {} carries no pixels (read back from a log?)",
                frame.sequence
            )));
        }
        let (mut left, mut right) = std::mem::take(&mut self.input);
        let grid = copy_gray_into(frame.left(), frame.width, frame.height, &mut left)
            .and_then(|()| copy_gray_into(frame.right(), frame.width, frame.height, &mut right))
            .and_then(|()| self.grid(&left, &right, frame.time, frame.sequence));
        self.input = (left, right);
        grid
    }

    /// The depth grid of a raw grey pair captured at `time`, frame `sequence` at its source.
    /// The same grid as [`StereoPipeline::depth`]'s map would give, summarised straight from
    /// the matcher's output without a depth map ([`DepthGridder::grid_fixed_point`]).
    pub fn grid(
        &mut self,
        left: &Mat,
        right: &Mat,
        time: Time,
        sequence: u64,
    ) -> Result<DepthGrid, VisionError> {
        let start = Instant::now();
        let (left, right) = prepared(
            self.rectifier.as_ref(),
            self.shrink(),
            &mut self.rectified,
            &mut self.small,
            left,
            right,
        )?;
        let matching = Instant::now();
        self.times.rectify = matching - start;
        let raw = self.matcher.compute_raw(left, right)?;
        let textureless = match &mut self.texture {
            Some(texture) => Some(texture.textureless(left)?),
            None => None,
        };
        self.times.matching = matching.elapsed();
        let start = Instant::now();
        let values = raw.data_typed::<i16>().cv("disparity pixels")?;
        let (width, height) = (raw.cols() as usize, raw.rows() as usize);
        let grid = self.gridder.grid_fixed_point(
            values,
            textureless,
            width,
            height,
            &self.fixed_point_depth,
            time,
            sequence,
        )?;
        self.times.depth = Duration::ZERO;
        self.times.grid = start.elapsed();
        Ok(grid)
    }

    /// Depth of a raw grey pair (m).
    pub fn depth(&mut self, left: &Mat, right: &Mat) -> Result<DepthMap, VisionError> {
        let disparity = self.disparity(left, right)?;
        let start = Instant::now();
        let depth = DepthMap::from_disparity(&disparity, &self.geometry);
        self.times.depth = start.elapsed();
        Ok(depth)
    }

    /// Disparity of a raw grey pair at the pair's own size (px), each matched pixel spread
    /// over the block it stands for: for scoring the pipeline against full-size ground truth.
    pub fn full_size_disparity(&mut self, left: &Mat, right: &Mat) -> Result<DisparityMap, VisionError> {
        let size = left.size().cv("left size")?;
        let disparity = self.disparity(left, right)?;
        let (fx, fy) = (self.downscale as usize, (self.downscale * self.row_downscale) as usize);
        Ok(disparity.upscaled(fx, fy, size.width as usize, size.height as usize))
    }

    /// Disparity of a raw grey pair (px, at the downscaled size).
    pub fn disparity(&mut self, left: &Mat, right: &Mat) -> Result<DisparityMap, VisionError> {
        let start = Instant::now();
        let (left, right) = prepared(
            self.rectifier.as_ref(),
            self.shrink(),
            &mut self.rectified,
            &mut self.small,
            left,
            right,
        )?;
        let matching = Instant::now();
        self.times.rectify = matching - start;
        let mut disparity = self.matcher.compute(left, right)?;
        if let Some(texture) = &mut self.texture {
            texture.apply(left, &mut disparity)?;
        }
        self.times.matching = matching.elapsed();
        Ok(disparity)
    }

    /// The column and row shrink factors, `None` at full size.
    fn shrink(&self) -> Option<(f64, f64)> {
        (self.downscale > 1 || self.row_downscale > 1).then(|| {
            let fx = 1.0 / f64::from(self.downscale);
            (fx, fx / f64::from(self.row_downscale))
        })
    }
}

/// The pair the matcher sees: rectified into `rectified` if there is a `rectifier`, then
/// shrunk by `shrink` (column and row factors) into `small`.
fn prepared<'a>(
    rectifier: Option<&Rectifier>,
    shrink: Option<(f64, f64)>,
    rectified: &'a mut (Mat, Mat),
    small: &'a mut (Mat, Mat),
    mut left: &'a Mat,
    mut right: &'a Mat,
) -> Result<(&'a Mat, &'a Mat), VisionError> {
    if let Some(rectifier) = rectifier {
        rectifier.rectify_into(left, right, &mut rectified.0, &mut rectified.1)?;
        (left, right) = (&rectified.0, &rectified.1);
    }
    if let Some((fx, fy)) = shrink {
        imgproc::resize(left, &mut small.0, Size::default(), fx, fy, imgproc::INTER_AREA)
            .cv("shrinking the left image")?;
        imgproc::resize(right, &mut small.1, Size::default(), fx, fy, imgproc::INTER_AREA)
            .cv("shrinking the right image")?;
        (left, right) = (&small.0, &small.1);
    }
    Ok((left, right))
}
