//! Stereo calibration (thesis §3.2.2–3.2.3): per-camera intrinsics, the right camera's pose
//! relative to the left, and the rectifying rotations and projections, from chessboard
//! corners seen by both cameras.
//!
//! Frames: OpenCV camera frames (x right, y down, z along the optical axis); `r`, `t` map
//! points from the left camera's frame into the right camera's. Lengths are in the unit of
//! [`Board::square_m`] (m).

use opencv::calib3d;
use opencv::core::{Mat, Point2f, Point3f, Size, TermCriteria, TermCriteria_COUNT, TermCriteria_EPS, Vector};

use crate::board::Board;
use crate::error::{CvContext, VisionError};
use crate::mat::{from_flat, from_rows, to_flat, to_rows};

/// A calibrated, rectified stereo pair, as stored in the calibration file.
#[derive(Clone, Debug, PartialEq)]
pub struct StereoCalibration {
    /// Image size the calibration holds for (px).
    pub image_width: u32,
    /// Image size the calibration holds for (px).
    pub image_height: u32,
    /// Left camera matrix `[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]` (px).
    pub k1: [[f64; 3]; 3],
    /// Left distortion `(k1, k2, p1, p2, k3)`.
    pub d1: Vec<f64>,
    /// Right camera matrix (px).
    pub k2: [[f64; 3]; 3],
    /// Right distortion `(k1, k2, p1, p2, k3)`.
    pub d2: Vec<f64>,
    /// Rotation from the left camera frame into the right camera frame.
    pub r: [[f64; 3]; 3],
    /// Translation from the left camera frame into the right camera frame (m); the baseline
    /// is `-t[0]` for a side-by-side pair.
    pub t: [f64; 3],
    /// Rectifying rotation of the left camera.
    pub r1: [[f64; 3]; 3],
    /// Rectifying rotation of the right camera.
    pub r2: [[f64; 3]; 3],
    /// Projection of the left rectified camera (px).
    pub p1: [[f64; 4]; 3],
    /// Projection of the right rectified camera (px, last column `Tx·f`).
    pub p2: [[f64; 4]; 3],
    /// Disparity-to-depth matrix: `[X Y Z W]ᵀ = Q·[u v d 1]ᵀ`, depth `Z/W` (m).
    pub q: [[f64; 4]; 4],
    /// RMS reprojection error of the stereo calibration (px).
    pub rms_px: f64,
    /// Multiplies every computed depth: the one-number correction from measured reference
    /// distances (thesis §3.2.5); 1 when none was measured.
    pub depth_scale: f64,
}

/// The corners of one board view seen by both cameras (px).
#[derive(Clone, Debug)]
pub struct PairCorners {
    pub left: Vector<Point2f>,
    pub right: Vector<Point2f>,
}

/// What a calibration produced besides the calibration itself.
#[derive(Clone, Debug)]
pub struct StereoSolution {
    pub calibration: StereoCalibration,
    /// Left camera's own RMS reprojection error (px).
    pub left_rms_px: f64,
    /// Right camera's own RMS reprojection error (px).
    pub right_rms_px: f64,
    /// RMS reprojection error of each view in the stereo solution, `[left, right]` (px).
    pub per_pair_rms_px: Vec<[f64; 2]>,
    /// Mean |row difference| of matching corners after rectification (px): 0 for a perfect
    /// rectification.
    pub rectified_row_error_px: f64,
}

fn criteria(iterations: i32) -> Result<TermCriteria, VisionError> {
    TermCriteria::new(TermCriteria_COUNT + TermCriteria_EPS, iterations, 1e-6).cv("TermCriteria")
}

/// Calibrates both cameras and the pair from `pairs` of `board` views in images of `size`,
/// then rectifies with `alpha` (0 = crop to valid pixels, 1 = keep every source pixel).
pub fn calibrate_pair(
    board: &Board,
    size: Size,
    pairs: &[PairCorners],
    alpha: f64,
) -> Result<StereoSolution, VisionError> {
    if pairs.len() < 3 {
        return Err(VisionError::Input(format!(
            "stereo calibration needs at least 3 board views seen by both cameras, got {}",
            pairs.len()
        )));
    }
    let object: Vector<Vector<Point3f>> = pairs.iter().map(|_| board.object_points()).collect();
    let left: Vector<Vector<Point2f>> = pairs.iter().map(|p| p.left.clone()).collect();
    let right: Vector<Vector<Point2f>> = pairs.iter().map(|p| p.right.clone()).collect();

    let (mut k1, mut d1, left_rms_px) = calibrate_camera(&object, &left, size, "left")?;
    let (mut k2, mut d2, right_rms_px) = calibrate_camera(&object, &right, size, "right")?;

    let (mut r, mut t, mut e, mut f, mut per_view) =
        (Mat::default(), Mat::default(), Mat::default(), Mat::default(), Mat::default());
    let rms_px = calib3d::stereo_calibrate_extended(
        &object,
        &left,
        &right,
        &mut k1,
        &mut d1,
        &mut k2,
        &mut d2,
        size,
        &mut r,
        &mut t,
        &mut e,
        &mut f,
        &mut per_view,
        calib3d::CALIB_USE_INTRINSIC_GUESS,
        criteria(100)?,
    )
    .cv("stereoCalibrate")?;

    let (mut r1, mut r2, mut p1, mut p2, mut q) =
        (Mat::default(), Mat::default(), Mat::default(), Mat::default(), Mat::default());
    calib3d::stereo_rectify(
        &k1,
        &d1,
        &k2,
        &d2,
        size,
        &r,
        &t,
        &mut r1,
        &mut r2,
        &mut p1,
        &mut p2,
        &mut q,
        calib3d::CALIB_ZERO_DISPARITY,
        alpha,
        size,
        None,
        None,
    )
    .cv("stereoRectify")?;

    let t = to_rows::<3, 1>(&t, "T")?;
    let calibration = StereoCalibration {
        image_width: size.width as u32,
        image_height: size.height as u32,
        k1: to_rows(&k1, "K1")?,
        d1: to_flat(&d1, "D1")?,
        k2: to_rows(&k2, "K2")?,
        d2: to_flat(&d2, "D2")?,
        r: to_rows(&r, "R")?,
        t: [t[0][0], t[1][0], t[2][0]],
        r1: to_rows(&r1, "R1")?,
        r2: to_rows(&r2, "R2")?,
        p1: to_rows(&p1, "P1")?,
        p2: to_rows(&p2, "P2")?,
        q: to_rows(&q, "Q")?,
        rms_px,
        depth_scale: 1.0,
    };
    let per_pair_rms_px = to_flat(&per_view, "per-view errors")?.chunks(2).map(|c| [c[0], c[1]]).collect();
    let rectified_row_error_px = rectified_row_error_px(&calibration, pairs)?;
    Ok(StereoSolution { calibration, left_rms_px, right_rms_px, per_pair_rms_px, rectified_row_error_px })
}

fn calibrate_camera(
    object: &Vector<Vector<Point3f>>,
    image: &Vector<Vector<Point2f>>,
    size: Size,
    which: &str,
) -> Result<(Mat, Mat, f64), VisionError> {
    let (mut k, mut d, mut rvecs, mut tvecs) =
        (Mat::default(), Mat::default(), Vector::<Mat>::new(), Vector::<Mat>::new());
    let rms = calib3d::calibrate_camera(
        object,
        image,
        size,
        &mut k,
        &mut d,
        &mut rvecs,
        &mut tvecs,
        0,
        criteria(100)?,
    )
    .cv_with(|| format!("calibrateCamera ({which} camera)"))?;
    Ok((k, d, rms))
}

/// Mean |row difference| (px) between the left and right corners of `pairs` once both are
/// undistorted and rectified with `calibration`.
pub fn rectified_row_error_px(
    calibration: &StereoCalibration,
    pairs: &[PairCorners],
) -> Result<f64, VisionError> {
    let left = rectify_points(calibration, Side::Left, pairs.iter().map(|p| &p.left))?;
    let right = rectify_points(calibration, Side::Right, pairs.iter().map(|p| &p.right))?;
    if left.is_empty() || left.len() != right.len() {
        return Err(VisionError::Input("no matching corners to compare after rectification".into()));
    }
    let total: f64 = left.iter().zip(&right).map(|(l, r)| f64::from((l.y - r.y).abs())).sum();
    Ok(total / left.len() as f64)
}

#[derive(Clone, Copy)]
enum Side {
    Left,
    Right,
}

fn rectify_points<'a>(
    c: &StereoCalibration,
    side: Side,
    views: impl Iterator<Item = &'a Vector<Point2f>>,
) -> Result<Vec<Point2f>, VisionError> {
    let (k, d, r, p) = match side {
        Side::Left => (&c.k1, &c.d1, &c.r1, &c.p1),
        Side::Right => (&c.k2, &c.d2, &c.r2, &c.p2),
    };
    let (k, d, r, p) = (from_rows(k)?, from_flat(d)?, from_rows(r)?, from_rows(p)?);
    let mut out = Vec::new();
    for view in views {
        let mut rectified = Vector::<Point2f>::new();
        calib3d::undistort_points(view, &mut rectified, &k, &d, &r, &p).cv("undistortPoints")?;
        out.extend(rectified.iter());
    }
    Ok(out)
}

/// The least-squares scale `s` minimising Σ (s·measured − true)² over reference distances
/// `(measured_m, true_m)` (thesis §3.2.5), for [`StereoCalibration::depth_scale`].
pub fn depth_scale_from_references(references: &[(f64, f64)]) -> Result<f64, VisionError> {
    if let Some(bad) =
        references.iter().find(|(m, t)| !(m.is_finite() && t.is_finite() && *m > 0.0 && *t > 0.0))
    {
        return Err(VisionError::Params(format!(
            "reference distance {} m measured as {} m: both must be positive",
            bad.1, bad.0
        )));
    }
    let (mt, mm) = references.iter().fold((0.0, 0.0), |(mt, mm), (m, t)| (mt + m * t, mm + m * m));
    if mm == 0.0 {
        return Err(VisionError::Params("depth scale needs at least one reference distance".into()));
    }
    Ok(mt / mm)
}
