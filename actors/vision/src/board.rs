//! The chessboard calibration target and its corners in an image.

use opencv::calib3d;
use opencv::core::{Mat, Point2f, Point3f, Size, TermCriteria, TermCriteria_COUNT, TermCriteria_EPS, Vector};
use opencv::imgproc;

use crate::error::{CvContext, VisionError};

/// A planar chessboard, counted in *inner* corners (OpenCV's sample board is 9×6).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Board {
    /// Inner corners along a row.
    pub cols: u32,
    /// Inner corners along a column.
    pub rows: u32,
    /// Side of one square (m); it sets the unit of the calibrated baseline and depth.
    pub square_m: f64,
}

impl Board {
    /// A board of `cols`×`rows` inner corners with squares of `square_m` metres.
    pub fn new(cols: u32, rows: u32, square_m: f64) -> Result<Board, VisionError> {
        if cols < 2 || rows < 2 || cols > 100 || rows > 100 {
            return Err(VisionError::Params(format!(
                "board {cols}×{rows}: needs 2..=100 inner corners each way"
            )));
        }
        if !(square_m.is_finite() && square_m > 0.0) {
            return Err(VisionError::Params(format!("board square size {square_m} m must be positive")));
        }
        Ok(Board { cols, rows, square_m })
    }

    /// Inner corners on the board.
    pub fn corner_count(&self) -> usize {
        (self.cols * self.rows) as usize
    }

    fn pattern(&self) -> Size {
        Size::new(self.cols as i32, self.rows as i32)
    }

    /// The corners in the board's own frame (m, z = 0), in OpenCV's detection order.
    pub fn object_points(&self) -> Vector<Point3f> {
        (0..self.rows)
            .flat_map(|r| {
                (0..self.cols).map(move |c| {
                    Point3f::new((c as f64 * self.square_m) as f32, (r as f64 * self.square_m) as f32, 0.0)
                })
            })
            .collect()
    }

    /// The board's inner corners in grey `image` (px), refined to sub-pixel accuracy; `None`
    /// when the whole board is not visible.
    pub fn find_corners(&self, image: &Mat) -> Result<Option<Vector<Point2f>>, VisionError> {
        let mut corners = Vector::<Point2f>::new();
        let flags = calib3d::CALIB_CB_ADAPTIVE_THRESH | calib3d::CALIB_CB_NORMALIZE_IMAGE;
        let found = calib3d::find_chessboard_corners(image, self.pattern(), &mut corners, flags)
            .cv("findChessboardCorners")?;
        if !found || corners.len() != self.corner_count() {
            return Ok(None);
        }
        let criteria =
            TermCriteria::new(TermCriteria_COUNT + TermCriteria_EPS, 30, 0.01).cv("TermCriteria")?;
        imgproc::corner_sub_pix(image, &mut corners, Size::new(11, 11), Size::new(-1, -1), criteria)
            .cv("cornerSubPix")?;
        Ok(Some(corners))
    }
}
