//! Disparity by block matching (thesis §3.2.4): OpenCV's semi-global matcher (Hirschmüller)
//! and its fast local block matcher, with every parameter in the config.

use opencv::calib3d::{self, StereoBM, StereoSGBM};
use opencv::core::{CV_16S, Mat, MatTraitConst, Ptr};
use opencv::prelude::*;
use serde::{Deserialize, Serialize};

use crate::disparity_map::DisparityMap;
use crate::error::{CvContext, VisionError};

/// Which path directions the semi-global matcher aggregates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SgbmMode {
    /// 5 directions, one pass (OpenCV's default `MODE_SGBM`).
    Sgbm,
    /// All 8 directions, full-image memory (`MODE_HH`): slowest, most accurate.
    Hh,
    /// 4 directions (`MODE_HH4`).
    Hh4,
    /// 3 directions, parallel stripes (`MODE_SGBM_3WAY`): fastest.
    #[default]
    ThreeWay,
}

impl SgbmMode {
    fn opencv(self) -> i32 {
        match self {
            SgbmMode::Sgbm => calib3d::StereoSGBM_MODE_SGBM,
            SgbmMode::Hh => calib3d::StereoSGBM_MODE_HH,
            SgbmMode::Hh4 => calib3d::StereoSGBM_MODE_HH4,
            SgbmMode::ThreeWay => calib3d::StereoSGBM_MODE_SGBM_3WAY,
        }
    }
}

/// `cv::StereoSGBM` parameters; see OpenCV's documentation for each. Disparities in px.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SgbmParams {
    pub min_disparity: i32,
    /// Disparity search range (px), a positive multiple of 16.
    pub num_disparities: i32,
    /// Matched block side (px), odd, 1..=11 is typical.
    pub block_size: i32,
    /// Penalty of a ±1 disparity change between neighbours.
    pub p1: i32,
    /// Penalty of a larger disparity change; must exceed `p1`.
    pub p2: i32,
    /// Largest left-right consistency difference (px); negative disables the check.
    pub disp12_max_diff: i32,
    pub pre_filter_cap: i32,
    /// Margin (%) by which the best cost must beat the second best.
    pub uniqueness_ratio: i32,
    /// Largest speckle (px) to invalidate; 0 disables the filter.
    pub speckle_window_size: i32,
    /// Largest disparity variation inside a connected component (px).
    pub speckle_range: i32,
    pub mode: SgbmMode,
}

impl Default for SgbmParams {
    /// 3-way SGBM with a 3-px block (P1 = 8·9, P2 = 32·9), pre-filter cap 15, uniqueness 5 %,
    /// speckle filter 100 px / 2 px, left-right check 1 px. Chosen by a small grid search on
    /// the Middlebury cones, teddy and reindeer pairs: lower bad-2 on all three than OpenCV's
    /// StereoSGBM with the data README's settings (5-px block, uniqueness 10), at the same speed
    /// as OpenCV's 3-way mode with those settings.
    fn default() -> Self {
        SgbmParams {
            min_disparity: 0,
            num_disparities: 64,
            block_size: 3,
            p1: 8 * 9,
            p2: 32 * 9,
            disp12_max_diff: 1,
            pre_filter_cap: 15,
            uniqueness_ratio: 5,
            speckle_window_size: 100,
            speckle_range: 2,
            mode: SgbmMode::ThreeWay,
        }
    }
}

/// `cv::StereoBM` parameters (the fast local matcher). Disparities in px.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BmParams {
    pub min_disparity: i32,
    /// Disparity search range (px), a positive multiple of 16.
    pub num_disparities: i32,
    /// Matched block side (px), odd, 5..=255.
    pub block_size: i32,
    pub pre_filter_size: i32,
    pub pre_filter_cap: i32,
    pub texture_threshold: i32,
    pub uniqueness_ratio: i32,
    pub speckle_window_size: i32,
    pub speckle_range: i32,
    pub disp12_max_diff: i32,
}

impl Default for BmParams {
    fn default() -> Self {
        BmParams {
            min_disparity: 0,
            num_disparities: 64,
            block_size: 15,
            pre_filter_size: 9,
            pre_filter_cap: 31,
            texture_threshold: 10,
            uniqueness_ratio: 15,
            speckle_window_size: 100,
            speckle_range: 2,
            disp12_max_diff: 1,
        }
    }
}

/// Which matcher, with its parameters (`algorithm = "sgbm"` or `"bm"` in the config).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "algorithm", rename_all = "snake_case")]
pub enum MatcherParams {
    Sgbm(SgbmParams),
    Bm(BmParams),
}

impl Default for MatcherParams {
    fn default() -> Self {
        MatcherParams::Sgbm(SgbmParams::default())
    }
}

impl MatcherParams {
    /// The disparity search range (px).
    pub fn num_disparities(&self) -> i32 {
        match self {
            MatcherParams::Sgbm(p) => p.num_disparities,
            MatcherParams::Bm(p) => p.num_disparities,
        }
    }

    /// The same matcher searching `num_disparities` (e.g. after a downscale).
    pub fn with_num_disparities(&self, num_disparities: i32) -> MatcherParams {
        let mut p = self.clone();
        match &mut p {
            MatcherParams::Sgbm(s) => s.num_disparities = num_disparities,
            MatcherParams::Bm(b) => b.num_disparities = num_disparities,
        }
        p
    }
}

fn check_range(
    min_disparity: i32,
    num_disparities: i32,
    block_size: i32,
    max_block: i32,
) -> Result<(), VisionError> {
    if num_disparities <= 0 || num_disparities % 16 != 0 || num_disparities > 1024 {
        return Err(VisionError::Params(format!(
            "num_disparities {num_disparities} must be a multiple of 16 in 16..=1024"
        )));
    }
    if block_size % 2 == 0 || !(1..=max_block).contains(&block_size) {
        return Err(VisionError::Params(format!("block_size {block_size} must be odd in 1..={max_block}")));
    }
    if !(-1024..=1024).contains(&min_disparity) {
        return Err(VisionError::Params(format!("min_disparity {min_disparity} out of -1024..=1024")));
    }
    Ok(())
}

enum Engine {
    Sgbm(Ptr<StereoSGBM>),
    Bm(Ptr<StereoBM>),
}

/// A configured matcher; reuse it across frames (it keeps its working buffers).
pub struct Matcher {
    engine: Engine,
    min_disparity: i32,
    num_disparities: i32,
    /// Raw fixed-point output (1/16 px), kept to avoid reallocating per frame.
    raw: Mat,
}

impl Matcher {
    /// Builds the matcher, rejecting out-of-range parameters.
    pub fn new(params: &MatcherParams) -> Result<Matcher, VisionError> {
        let (engine, min_disparity, num_disparities) = match params {
            MatcherParams::Sgbm(p) => {
                check_range(p.min_disparity, p.num_disparities, p.block_size, 51)?;
                if p.p1 < 0 || p.p2 <= p.p1 {
                    return Err(VisionError::Params(format!(
                        "SGBM penalties need 0 ≤ p1 < p2, got p1 {} p2 {}",
                        p.p1, p.p2
                    )));
                }
                let m = StereoSGBM::create(
                    p.min_disparity,
                    p.num_disparities,
                    p.block_size,
                    p.p1,
                    p.p2,
                    p.disp12_max_diff,
                    p.pre_filter_cap,
                    p.uniqueness_ratio,
                    p.speckle_window_size,
                    p.speckle_range,
                    p.mode.opencv(),
                )
                .cv("StereoSGBM::create")?;
                (Engine::Sgbm(m), p.min_disparity, p.num_disparities)
            }
            MatcherParams::Bm(p) => {
                check_range(p.min_disparity, p.num_disparities, p.block_size, 255)?;
                if p.block_size < 5 {
                    return Err(VisionError::Params(format!(
                        "StereoBM block_size {} must be at least 5",
                        p.block_size
                    )));
                }
                if p.pre_filter_size % 2 == 0 || !(5..=255).contains(&p.pre_filter_size) {
                    return Err(VisionError::Params(format!(
                        "pre_filter_size {} must be odd in 5..=255",
                        p.pre_filter_size
                    )));
                }
                if !(1..=63).contains(&p.pre_filter_cap) {
                    return Err(VisionError::Params(format!(
                        "pre_filter_cap {} must be in 1..=63",
                        p.pre_filter_cap
                    )));
                }
                let mut m = StereoBM::create(p.num_disparities, p.block_size).cv("StereoBM::create")?;
                m.set_min_disparity(p.min_disparity).cv("StereoBM min_disparity")?;
                m.set_pre_filter_size(p.pre_filter_size).cv("StereoBM pre_filter_size")?;
                m.set_pre_filter_cap(p.pre_filter_cap).cv("StereoBM pre_filter_cap")?;
                m.set_texture_threshold(p.texture_threshold).cv("StereoBM texture_threshold")?;
                m.set_uniqueness_ratio(p.uniqueness_ratio).cv("StereoBM uniqueness_ratio")?;
                m.set_speckle_window_size(p.speckle_window_size).cv("StereoBM speckle_window_size")?;
                m.set_speckle_range(p.speckle_range).cv("StereoBM speckle_range")?;
                m.set_disp12_max_diff(p.disp12_max_diff).cv("StereoBM disp12_max_diff")?;
                (Engine::Bm(m), p.min_disparity, p.num_disparities)
            }
        };
        Ok(Matcher { engine, min_disparity, num_disparities, raw: Mat::default() })
    }

    /// The disparity search range (px).
    pub fn num_disparities(&self) -> i32 {
        self.num_disparities
    }

    /// The smallest disparity searched (px).
    pub fn min_disparity(&self) -> i32 {
        self.min_disparity
    }

    /// Matches rectified 8-bit grey images of equal size; the disparity is the left image's
    /// (px, positive when the right view sees a point further left).
    pub fn compute(&mut self, left: &Mat, right: &Mat) -> Result<DisparityMap, VisionError> {
        let min_disparity = self.min_disparity;
        DisparityMap::from_fixed_point(self.compute_raw(left, right)?, min_disparity)
    }

    /// As [`Matcher::compute`], but OpenCV's own output: continuous `CV_16S` in 1/16 px, below
    /// `min_disparity · 16` where invalid (see [`DisparityMap::from_fixed_point`]), in the
    /// matcher's buffer until the next call. For a caller that converts it in one pass.
    pub fn compute_raw(&mut self, left: &Mat, right: &Mat) -> Result<&Mat, VisionError> {
        let (ls, rs) = (left.size().cv("left size")?, right.size().cv("right size")?);
        if ls != rs {
            return Err(VisionError::Input(format!(
                "left image is {}×{} but right is {}×{}",
                ls.width, ls.height, rs.width, rs.height
            )));
        }
        for (side, m) in [("left", left.typ()), ("right", right.typ())] {
            if m != opencv::core::CV_8UC1 {
                return Err(VisionError::Input(format!(
                    "{side} image must be 8-bit grey, has OpenCV type {m}"
                )));
            }
        }
        if ls.width <= self.num_disparities {
            return Err(VisionError::Input(format!(
                "a {}-px wide image cannot hold a {}-px disparity search",
                ls.width, self.num_disparities
            )));
        }
        match &mut self.engine {
            Engine::Sgbm(m) => m.compute(left, right, &mut self.raw).cv("StereoSGBM::compute")?,
            Engine::Bm(m) => m.compute(left, right, &mut self.raw).cv("StereoBM::compute")?,
        }
        if self.raw.typ() != CV_16S || !self.raw.is_continuous() {
            return Err(VisionError::Input(format!(
                "matcher returned OpenCV type {} (continuous: {})",
                self.raw.typ(),
                self.raw.is_continuous()
            )));
        }
        Ok(&self.raw)
    }
}
