//! Rectification (thesis §3.2.3): lookup maps computed once per calibration, applied to every
//! frame with `remap`, so matching rows in the two images see the same scene row.

use opencv::calib3d;
use opencv::core::{BORDER_CONSTANT, CV_16SC2, Mat, MatTraitConst, Scalar, Size};
use opencv::imgproc;

use crate::calibration::StereoCalibration;
use crate::error::{CvContext, VisionError};
use crate::mat::{from_flat, from_rows};

/// Undistorts and rectifies stereo pairs with one calibration.
pub struct Rectifier {
    size: Size,
    left: (Mat, Mat),
    right: (Mat, Mat),
}

impl Rectifier {
    /// Computes both cameras' maps (fixed-point `CV_16SC2`, the fastest for `remap`).
    pub fn new(calibration: &StereoCalibration) -> Result<Rectifier, VisionError> {
        let too_large = || VisionError::Params("calibration image size too large".into());
        let size = Size::new(
            i32::try_from(calibration.image_width).map_err(|_| too_large())?,
            i32::try_from(calibration.image_height).map_err(|_| too_large())?,
        );
        let c = calibration;
        let map = |k, d: &[f64], r, p, which: &str| -> Result<(Mat, Mat), VisionError> {
            let (mut m1, mut m2) = (Mat::default(), Mat::default());
            calib3d::init_undistort_rectify_map(
                &from_rows::<3>(k)?,
                &from_flat(d)?,
                &from_rows::<3>(r)?,
                &from_rows::<4>(p)?,
                size,
                CV_16SC2,
                &mut m1,
                &mut m2,
            )
            .cv_with(|| format!("initUndistortRectifyMap ({which} camera)"))?;
            Ok((m1, m2))
        };
        Ok(Rectifier {
            size,
            left: map(&c.k1, &c.d1, &c.r1, &c.p1, "left")?,
            right: map(&c.k2, &c.d2, &c.r2, &c.p2, "right")?,
        })
    }

    /// Image size the maps expect and produce (px): `(width, height)`.
    pub fn size(&self) -> (u32, u32) {
        (self.size.width as u32, self.size.height as u32)
    }

    /// Rectifies a raw pair into `left_out`, `right_out` (buffers reused across frames).
    pub fn rectify_into(
        &self,
        left: &Mat,
        right: &Mat,
        left_out: &mut Mat,
        right_out: &mut Mat,
    ) -> Result<(), VisionError> {
        for (side, image) in [("left", left), ("right", right)] {
            let s = image.size().cv("image size")?;
            if s != self.size {
                return Err(VisionError::Input(format!(
                    "{side} image is {}×{} but the calibration is for {}×{}",
                    s.width, s.height, self.size.width, self.size.height
                )));
            }
        }
        let remap = |src: &Mat, maps: &(Mat, Mat), dst: &mut Mat, which: &str| {
            imgproc::remap(
                src,
                dst,
                &maps.0,
                &maps.1,
                imgproc::INTER_LINEAR,
                BORDER_CONSTANT,
                Scalar::default(),
            )
            .cv_with(|| format!("remap ({which} image)"))
        };
        remap(left, &self.left, left_out, "left")?;
        remap(right, &self.right, right_out, "right")
    }
}
