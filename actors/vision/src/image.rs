//! Loading images and moving 8-bit grey pixels between OpenCV `Mat`s and plain buffers.

use std::path::Path;

use opencv::core::{CV_8UC1, Mat, MatTraitConst, MatTraitConstManual, MatTraitManual, Rect, Scalar};
use opencv::{imgcodecs, imgproc};

use crate::error::{CvContext, VisionError};

/// Reads `path` as an 8-bit grey image (colour images are converted).
pub fn load_gray(path: &Path) -> Result<Mat, VisionError> {
    let name = path.to_string_lossy();
    if !path.is_file() {
        return Err(VisionError::BadFile { path: path.to_owned(), what: "no such image file".into() });
    }
    let image = imgcodecs::imread(path, imgcodecs::IMREAD_GRAYSCALE).cv_with(|| format!("reading {name}"))?;
    if image.empty() {
        return Err(VisionError::BadFile { path: path.to_owned(), what: "not a readable image".into() });
    }
    Ok(image)
}

/// Reads `path` with its own depth and channels (ground-truth disparity PNG/PGM files).
pub fn load_unchanged(path: &Path) -> Result<Mat, VisionError> {
    let name = path.to_string_lossy();
    let image = imgcodecs::imread(path, imgcodecs::IMREAD_UNCHANGED).cv_with(|| format!("reading {name}"))?;
    if image.empty() {
        return Err(VisionError::BadFile { path: path.to_owned(), what: "not a readable image".into() });
    }
    Ok(image)
}

/// Converts any 1-, 3- or 4-channel 8-bit image to grey (a grey image is copied as is).
pub fn to_gray(image: &Mat) -> Result<Mat, VisionError> {
    let mut gray = Mat::default();
    match image.channels() {
        1 => return Ok(image.clone()),
        3 => imgproc::cvt_color_def(image, &mut gray, imgproc::COLOR_BGR2GRAY).cv("BGR to grey")?,
        4 => imgproc::cvt_color_def(image, &mut gray, imgproc::COLOR_BGRA2GRAY).cv("BGRA to grey")?,
        n => return Err(VisionError::Input(format!("cannot convert a {n}-channel image to grey"))),
    }
    Ok(gray)
}

/// A copy of the `width`×`height` window of `image` whose top-left pixel is (`x`, `y`).
pub fn crop(image: &Mat, x: i32, y: i32, width: i32, height: i32) -> Result<Mat, VisionError> {
    let size = image.size().cv("image size")?;
    if x < 0 || y < 0 || width <= 0 || height <= 0 || x + width > size.width || y + height > size.height {
        return Err(VisionError::Input(format!(
            "crop {width}×{height} at ({x}, {y}) does not fit a {}×{} image",
            size.width, size.height
        )));
    }
    let roi = Mat::roi(image, Rect::new(x, y, width, height)).cv("crop")?;
    roi.try_clone().cv("crop copy")
}

/// The pixels of a continuous 8-bit single-channel `Mat`, row-major.
pub fn gray_bytes(image: &Mat) -> Result<Vec<u8>, VisionError> {
    if image.typ() != opencv::core::CV_8UC1 {
        return Err(VisionError::Input(format!(
            "expected an 8-bit grey image, got OpenCV type {}",
            image.typ()
        )));
    }
    if image.is_continuous() {
        return Ok(image.data_bytes().cv("image pixels")?.to_vec());
    }
    Ok(image.try_clone().cv("image copy")?.data_bytes().cv("image pixels")?.to_vec())
}

/// An owned 8-bit grey `Mat` holding a copy of `pixels` (`width`×`height`, row-major).
pub fn gray_mat(pixels: &[u8], width: u32, height: u32) -> Result<Mat, VisionError> {
    let mut image = Mat::default();
    copy_gray_into(pixels, width, height, &mut image)?;
    Ok(image)
}

/// Copies `pixels` (`width`×`height`, row-major, 8-bit grey) into `image`, reallocating it only
/// when its size or type differs: how each frame enters the pipeline (a fresh `Mat` per frame
/// cost an allocation and 2 × 300 kB of page faults at VGA).
pub fn copy_gray_into(pixels: &[u8], width: u32, height: u32, image: &mut Mat) -> Result<(), VisionError> {
    let (w, h) = (width as usize, height as usize);
    if pixels.len() != w * h || w == 0 || h == 0 {
        return Err(VisionError::Input(format!(
            "a {width}×{height} grey image needs {} bytes, got {}",
            w * h,
            pixels.len()
        )));
    }
    let too_large = || VisionError::Input(format!("a {width}×{height} image is too large"));
    let rows = i32::try_from(height).map_err(|_| too_large())?;
    let cols = i32::try_from(width).map_err(|_| too_large())?;
    if image.rows() != rows || image.cols() != cols || image.typ() != CV_8UC1 || !image.is_continuous() {
        *image = Mat::new_rows_cols_with_default(rows, cols, CV_8UC1, Scalar::all(0.0))
            .cv("allocating an image")?;
    }
    image.data_bytes_mut().cv("image pixels")?.copy_from_slice(pixels);
    Ok(())
}
