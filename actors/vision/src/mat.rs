//! Small matrices between OpenCV `Mat`s (what the calibration functions take and return) and
//! plain Rust arrays (what we store, compare and test).

use opencv::core::{CV_64F, Mat, MatTraitConst, MatTraitConstManual};

use crate::error::{CvContext, VisionError};

/// The `R`×`C` matrix in `m` (any numeric type), or an error naming `what`.
pub fn to_rows<const R: usize, const C: usize>(m: &Mat, what: &str) -> Result<[[f64; C]; R], VisionError> {
    if m.rows() as usize != R || m.cols() as usize != C || m.channels() != 1 {
        return Err(VisionError::Input(format!(
            "{what}: expected a {R}×{C} matrix, got {}×{}×{}",
            m.rows(),
            m.cols(),
            m.channels()
        )));
    }
    let flat = to_flat(m, what)?;
    let mut out = [[0.0; C]; R];
    for (r, row) in out.iter_mut().enumerate() {
        row.copy_from_slice(&flat[r * C..(r + 1) * C]);
    }
    Ok(out)
}

/// Every element of single-channel `m`, row-major, as `f64`.
pub fn to_flat(m: &Mat, what: &str) -> Result<Vec<f64>, VisionError> {
    let mut converted = Mat::default();
    m.convert_to_def(&mut converted, CV_64F).cv_with(|| format!("{what}: converting to f64"))?;
    let converted = if converted.is_continuous() { converted } else { converted.try_clone().cv(what)? };
    Ok(converted.data_typed::<f64>().cv(what)?.to_vec())
}

/// A `Mat` of `f64` with the given rows.
pub fn from_rows<const C: usize>(rows: &[[f64; C]]) -> Result<Mat, VisionError> {
    Mat::from_slice_2d(rows).cv("building a matrix")
}

/// A single-row `Mat` of `f64` (distortion coefficients).
pub fn from_flat(values: &[f64]) -> Result<Mat, VisionError> {
    Mat::from_slice_2d(&[values]).cv("building a row vector")
}
