//! `kestrel disparity`: an image pair on disk → disparity file, scored when ground truth is
//! given.

use std::path::Path;

use opencv::core::Mat;

use crate::calibration::StereoCalibration;
use crate::disparity_file::write_disparity;
use crate::disparity_map::DisparityMap;
use crate::error::VisionError;
use crate::image::load_gray;
use crate::matcher::{Matcher, MatcherParams};
use crate::rectify::Rectifier;
use crate::score::{DisparityScores, GroundTruth, score};

/// What [`disparity`] produced.
#[derive(Clone, Debug)]
pub struct DisparityReport {
    pub disparity: DisparityMap,
    /// Present when ground truth was given.
    pub scores: Option<DisparityScores>,
}

/// Computes the disparity of the `left`/`right` pair with `matcher`, rectifying first when
/// a calibration file is given (otherwise the pair must already be rectified), writes it to
/// `out` (`.pfm`: Middlebury float, invalid = +∞; `.png`: 16-bit d·256, 0 = invalid) and, with
/// `ground_truth = Some((file, scale))`, scores it (file value = disparity · scale, 0 unknown).
pub fn disparity(
    left: &Path,
    right: &Path,
    calibration: Option<&Path>,
    ground_truth: Option<(&Path, f32)>,
    matcher: &MatcherParams,
    out: &Path,
) -> Result<DisparityReport, VisionError> {
    let (mut left_image, mut right_image) = (load_gray(left)?, load_gray(right)?);
    if let Some(path) = calibration {
        let rectifier = Rectifier::new(&StereoCalibration::load(path)?)?;
        let (mut l, mut r) = (Mat::default(), Mat::default());
        rectifier.rectify_into(&left_image, &right_image, &mut l, &mut r)?;
        (left_image, right_image) = (l, r);
    }
    let disparity = Matcher::new(matcher)?.compute(&left_image, &right_image)?;
    let scores = match ground_truth {
        Some((path, scale)) => {
            let truth = GroundTruth::load(path, scale)?;
            Some(
                score(&disparity, &truth, matcher.num_disparities() as usize)
                    .map_err(|e| VisionError::BadFile { path: path.to_owned(), what: e.to_string() })?,
            )
        }
        None => None,
    };
    write_disparity(&disparity, out)?;
    Ok(DisparityReport { disparity, scores })
}
