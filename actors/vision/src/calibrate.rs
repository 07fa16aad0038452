//! `kestrel calibrate`: chessboard image pairs on disk → calibration file and a report.

use std::path::{Path, PathBuf};

use opencv::core::{MatTraitConst, Size};

use crate::board::Board;
use crate::calibration::{PairCorners, StereoCalibration, calibrate_pair};
use crate::error::{CvContext, VisionError};
use crate::glob;
use crate::image::load_gray;

/// An image pair the calibration could not use, and why.
#[derive(Clone, Debug, PartialEq)]
pub struct SkippedPair {
    pub left: PathBuf,
    pub right: PathBuf,
    pub reason: String,
}

/// One image pair used by the calibration and its reprojection error (px).
#[derive(Clone, Debug, PartialEq)]
pub struct UsedPair {
    pub left: PathBuf,
    pub right: PathBuf,
    pub left_rms_px: f64,
    pub right_rms_px: f64,
}

/// What [`calibrate`] did.
#[derive(Clone, Debug)]
pub struct CalibrationReport {
    /// The calibration, as written to the output file.
    pub calibration: StereoCalibration,
    /// Pairs with the board found in both images, in file-name order.
    pub used: Vec<UsedPair>,
    /// Pairs without a complete board in one or both images (not fatal).
    pub skipped: Vec<SkippedPair>,
    /// Per-camera RMS reprojection errors before the joint solution (px).
    pub left_rms_px: f64,
    pub right_rms_px: f64,
    /// Mean |row difference| of matching corners after rectification (px).
    pub rectified_row_error_px: f64,
}

/// Calibrates a stereo camera from the chessboard images matching `left_glob` and
/// `right_glob` (paired in sorted file-name order), writes the calibration to `out_yaml`
/// and returns the report.
///
/// `board` is `(inner corner columns, inner corner rows)`, e.g. `(9, 6)`; `square_m` the
/// side of a square (m). Images where the board is not found are listed in the report.
pub fn calibrate(
    left_glob: &str,
    right_glob: &str,
    board: (u32, u32),
    square_m: f64,
    out_yaml: &Path,
) -> Result<CalibrationReport, VisionError> {
    let board = Board::new(board.0, board.1, square_m)?;
    let left = glob::expand(left_glob)?;
    let right = glob::expand(right_glob)?;
    if left.is_empty() {
        return Err(VisionError::Params(format!("no files match {left_glob}")));
    }
    if left.len() != right.len() {
        return Err(VisionError::Params(format!(
            "{} files match {left_glob} but {} match {right_glob}; they pair in sorted order",
            left.len(),
            right.len()
        )));
    }
    let mut size: Option<Size> = None;
    let mut corners = Vec::new();
    let mut found = Vec::new();
    let mut skipped = Vec::new();
    for (l, r) in left.iter().zip(&right) {
        let (li, ri) = (load_gray(l)?, load_gray(r)?);
        for (path, image) in [(l, &li), (r, &ri)] {
            let s = image.size().cv("image size")?;
            let first = *size.get_or_insert(s);
            if s != first {
                return Err(VisionError::BadFile {
                    path: path.clone(),
                    what: format!(
                        "image is {}×{}, the first one is {}×{}",
                        s.width, s.height, first.width, first.height
                    ),
                });
            }
        }
        let skip = |reason: &str| SkippedPair { left: l.clone(), right: r.clone(), reason: reason.into() };
        match (board.find_corners(&li)?, board.find_corners(&ri)?) {
            (Some(left), Some(right)) => {
                corners.push(PairCorners { left, right });
                found.push((l.clone(), r.clone()));
            }
            (None, Some(_)) => skipped.push(skip("board not found in the left image")),
            (Some(_), None) => skipped.push(skip("board not found in the right image")),
            (None, None) => skipped.push(skip("board not found in either image")),
        }
    }
    let size = size.ok_or_else(|| VisionError::Params(format!("no files match {left_glob}")))?;
    let solution = calibrate_pair(&board, size, &corners, 0.0)?;
    let used = found
        .into_iter()
        .zip(&solution.per_pair_rms_px)
        .map(|((left, right), &[left_rms_px, right_rms_px])| UsedPair {
            left,
            right,
            left_rms_px,
            right_rms_px,
        })
        .collect();
    solution.calibration.save(out_yaml)?;
    Ok(CalibrationReport {
        calibration: solution.calibration,
        used,
        skipped,
        left_rms_px: solution.left_rms_px,
        right_rms_px: solution.right_rms_px,
        rectified_row_error_px: solution.rectified_row_error_px,
    })
}
