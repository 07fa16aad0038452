//! The calibration file: OpenCV FileStorage YAML, so OpenCV's own tools (and `cv::FileStorage`
//! in any language) read it. Keys: `image_width`, `image_height`, `K1`, `D1`, `K2`, `D2`, `R`,
//! `T`, `R1`, `R2`, `P1`, `P2`, `Q`, `rms_px`, `depth_scale`.

use std::path::Path;

use opencv::core::{FileNode, FileStorage, FileStorage_READ, FileStorage_WRITE, Mat};
use opencv::prelude::*;

use crate::calibration::StereoCalibration;
use crate::error::{CvContext, VisionError};
use crate::mat::{from_flat, from_rows, to_flat, to_rows};

impl StereoCalibration {
    /// Writes the calibration to `path` (`.yaml`, `.yml` or `.xml`: OpenCV picks the format
    /// from the extension).
    pub fn save(&self, path: &Path) -> Result<(), VisionError> {
        let name = path.to_string_lossy();
        let what = |step: &str| format!("writing {name}: {step}");
        let mut fs = FileStorage::new(path, FileStorage_WRITE, "").cv_with(|| what("open"))?;
        if !fs.is_opened().cv_with(|| what("open"))? {
            return Err(VisionError::BadFile {
                path: path.to_owned(),
                what: "cannot be opened for writing".into(),
            });
        }
        let ints = [("image_width", self.image_width), ("image_height", self.image_height)];
        for (key, value) in ints {
            let value =
                i32::try_from(value).map_err(|_| VisionError::Input(format!("{key} {value} too large")))?;
            opencv::core::write_i32(&mut fs, key, value).cv_with(|| what(key))?;
        }
        let t = [[self.t[0]], [self.t[1]], [self.t[2]]];
        let mats: [(&str, Mat); 11] = [
            ("K1", from_rows(&self.k1)?),
            ("D1", from_flat(&self.d1)?),
            ("K2", from_rows(&self.k2)?),
            ("D2", from_flat(&self.d2)?),
            ("R", from_rows(&self.r)?),
            ("T", from_rows(&t)?),
            ("R1", from_rows(&self.r1)?),
            ("R2", from_rows(&self.r2)?),
            ("P1", from_rows(&self.p1)?),
            ("P2", from_rows(&self.p2)?),
            ("Q", from_rows(&self.q)?),
        ];
        for (key, mat) in &mats {
            opencv::core::write_mat(&mut fs, key, mat).cv_with(|| what(key))?;
        }
        for (key, value) in [("rms_px", self.rms_px), ("depth_scale", self.depth_scale)] {
            opencv::core::write_f64(&mut fs, key, value).cv_with(|| what(key))?;
        }
        fs.release().cv_with(|| what("close"))
    }

    /// Reads a calibration written by [`StereoCalibration::save`] (or by hand with the same
    /// keys); a missing or malformed entry is an error naming the file and the key.
    pub fn load(path: &Path) -> Result<StereoCalibration, VisionError> {
        if !path.is_file() {
            return Err(VisionError::BadFile {
                path: path.to_owned(),
                what: "no such calibration file".into(),
            });
        }
        let bad = |what: String| VisionError::BadFile { path: path.to_owned(), what };
        let fs = FileStorage::new(path, FileStorage_READ, "")
            .map_err(|e| bad(format!("not an OpenCV FileStorage file: {}", e.message)))?;
        if !fs.is_opened().cv("calibration file")? {
            return Err(bad("not an OpenCV FileStorage file".into()));
        }
        let node = |key: &str| -> Result<FileNode, VisionError> {
            let node = fs.get_node(key).map_err(|e| bad(format!("{key}: {}", e.message)))?;
            if node.empty().unwrap_or(true) {
                return Err(bad(format!("missing key {key}")));
            }
            Ok(node)
        };
        let mat = |key: &str| -> Result<Mat, VisionError> {
            let m = node(key)?.mat().map_err(|e| bad(format!("{key} is not a matrix: {}", e.message)))?;
            if m.empty() {
                return Err(bad(format!("{key} is not a matrix")));
            }
            Ok(m)
        };
        let real = |key: &str| -> Result<f64, VisionError> {
            let n = node(key)?;
            if !n.is_real().unwrap_or(false) && !n.is_int().unwrap_or(false) {
                return Err(bad(format!("{key} is not a number")));
            }
            n.real().map_err(|e| bad(format!("{key}: {}", e.message)))
        };
        let size = |key: &str| -> Result<u32, VisionError> {
            let v = real(key)?;
            if (1.0..=100_000.0).contains(&v) && v.fract() == 0.0 {
                Ok(v as u32)
            } else {
                Err(bad(format!("{key} = {v} is not an image size")))
            }
        };
        let shaped = |e: VisionError| bad(e.to_string());
        let t = to_flat(&mat("T")?, "T").map_err(shaped)?;
        let Ok(t) = <[f64; 3]>::try_from(t.as_slice()) else {
            return Err(bad(format!("T must have 3 elements, has {}", t.len())));
        };
        let calibration = StereoCalibration {
            image_width: size("image_width")?,
            image_height: size("image_height")?,
            k1: to_rows(&mat("K1")?, "K1").map_err(shaped)?,
            d1: to_flat(&mat("D1")?, "D1").map_err(shaped)?,
            k2: to_rows(&mat("K2")?, "K2").map_err(shaped)?,
            d2: to_flat(&mat("D2")?, "D2").map_err(shaped)?,
            r: to_rows(&mat("R")?, "R").map_err(shaped)?,
            t,
            r1: to_rows(&mat("R1")?, "R1").map_err(shaped)?,
            r2: to_rows(&mat("R2")?, "R2").map_err(shaped)?,
            p1: to_rows(&mat("P1")?, "P1").map_err(shaped)?,
            p2: to_rows(&mat("P2")?, "P2").map_err(shaped)?,
            q: to_rows(&mat("Q")?, "Q").map_err(shaped)?,
            rms_px: real("rms_px")?,
            depth_scale: real("depth_scale")?,
        };
        calibration.check().map_err(bad)?;
        Ok(calibration)
    }

    /// Checks what later steps rely on: finite numbers, camera matrices with positive focal
    /// lengths, rotations that are rotations, a usable `Q`, a positive depth scale. Each
    /// message names the key.
    pub fn check(&self) -> Result<(), String> {
        let matrices: [(&str, &[f64]); 9] = [
            ("K1", self.k1.as_flattened()),
            ("K2", self.k2.as_flattened()),
            ("R", self.r.as_flattened()),
            ("R1", self.r1.as_flattened()),
            ("R2", self.r2.as_flattened()),
            ("P1", self.p1.as_flattened()),
            ("P2", self.p2.as_flattened()),
            ("Q", self.q.as_flattened()),
            ("T", &self.t),
        ];
        for (key, values) in matrices.into_iter().chain([("D1", &self.d1[..]), ("D2", &self.d2[..])]) {
            if let Some(v) = values.iter().find(|v| !v.is_finite()) {
                return Err(format!("{key} contains the non-finite number {v}"));
            }
        }
        for (key, k) in [("K1", &self.k1), ("K2", &self.k2)] {
            let (fx, fy) = (k[0][0], k[1][1]);
            if !(fx > 0.0 && fy > 0.0) {
                return Err(format!("{key}: focal lengths fx = {fx}, fy = {fy} must be positive (px)"));
            }
            if k[1][0] != 0.0 || k[2] != [0.0, 0.0, 1.0] {
                return Err(format!(
                    "{key} is not a camera matrix: its rows must be [fx s cx], [0 fy cy], [0 0 1]"
                ));
            }
        }
        for (key, p) in [("P1", &self.p1), ("P2", &self.p2)] {
            if !(p[0][0] > 0.0 && p[1][1] > 0.0) {
                return Err(format!(
                    "{key}: focal lengths {} and {} must be positive (px)",
                    p[0][0], p[1][1]
                ));
            }
        }
        for (key, r) in [("R", &self.r), ("R1", &self.r1), ("R2", &self.r2)] {
            if let Some(e) = rotation_error(r) {
                return Err(format!("{key} is not a rotation: {e}"));
            }
        }
        if [4, 5, 8, 12, 14].iter().all(|n| self.d1.len() != *n) || self.d1.len() != self.d2.len() {
            return Err(format!(
                "distortion must have 4, 5, 8, 12 or 14 coefficients, has {} and {}",
                self.d1.len(),
                self.d2.len()
            ));
        }
        if !(self.q[2][3] > 0.0 && self.q[3][2] != 0.0) {
            return Err("Q has no focal length or baseline".into());
        }
        if !(self.depth_scale.is_finite() && self.depth_scale > 0.0) {
            return Err(format!("depth_scale {} must be positive", self.depth_scale));
        }
        Ok(())
    }
}

/// How far `r` is from a rotation, if farther than a calibration's rounding explains: `RᵀR`
/// must be the identity and the determinant +1, each within 1e-3 (a singular or scaled matrix
/// would rectify into nonsense).
fn rotation_error(r: &[[f64; 3]; 3]) -> Option<String> {
    const TOLERANCE: f64 = 1e-3;
    for i in 0..3 {
        for j in 0..3 {
            let dot: f64 = (0..3).map(|k| r[k][i] * r[k][j]).sum();
            let expected = if i == j { 1.0 } else { 0.0 };
            if (dot - expected).abs() > TOLERANCE {
                return Some(format!("column {i}·column {j} = {dot}, expected {expected}"));
            }
        }
    }
    let det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1])
        - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
        + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
    ((det - 1.0).abs() > TOLERANCE).then(|| format!("determinant {det}, expected 1"))
}
