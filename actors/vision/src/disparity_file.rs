//! Writing disparity maps: Middlebury's PFM (float, invalid = +∞) and KITTI's 16-bit PNG
//! (value = d·256, 0 = invalid).

use std::io::Write;
use std::path::Path;

use opencv::core::{CV_16UC1, Mat, MatTraitManual, Vector};
use opencv::imgcodecs;

use crate::disparity_map::DisparityMap;
use crate::error::{CvContext, VisionError};

/// Writes `disparity` to `path`, choosing the format by extension (`.pfm` or `.png`).
pub fn write_disparity(disparity: &DisparityMap, path: &Path) -> Result<(), VisionError> {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("pfm") => write_pfm(disparity, path),
        Some("png") => write_png16(disparity, path),
        _ => {
            Err(VisionError::Params(format!("{}: disparity output must end in .pfm or .png", path.display())))
        }
    }
}

/// Middlebury PFM: greyscale `Pf`, little-endian (negative scale), rows bottom to top.
fn write_pfm(disparity: &DisparityMap, path: &Path) -> Result<(), VisionError> {
    let mut bytes = format!("Pf\n{} {}\n-1.0\n", disparity.width, disparity.height).into_bytes();
    bytes.reserve(disparity.values.len() * 4);
    for row in disparity.values.chunks(disparity.width.max(1)).rev() {
        for &d in row {
            bytes.extend_from_slice(&(if d.is_nan() { f32::INFINITY } else { d }).to_le_bytes());
        }
    }
    let io = |source| VisionError::Io { path: path.to_owned(), source };
    std::fs::File::create(path).and_then(|mut f| f.write_all(&bytes)).map_err(io)
}

/// 16-bit PNG, value = round(d·256) (at least 1 so a valid zero disparity stays valid), 0 = invalid.
fn write_png16(disparity: &DisparityMap, path: &Path) -> Result<(), VisionError> {
    let rows =
        i32::try_from(disparity.height).map_err(|_| VisionError::Input("disparity too tall".into()))?;
    let cols = i32::try_from(disparity.width).map_err(|_| VisionError::Input("disparity too wide".into()))?;
    let mut image =
        Mat::new_rows_cols_with_default(rows, cols, CV_16UC1, 0.into()).cv("disparity PNG buffer")?;
    let pixels = image.data_typed_mut::<u16>().cv("disparity PNG pixels")?;
    for (p, &d) in pixels.iter_mut().zip(&disparity.values) {
        *p = if d.is_nan() || d < 0.0 { 0 } else { (d * 256.0).round().clamp(1.0, 65535.0) as u16 };
    }
    let name = path.to_string_lossy();
    let written = imgcodecs::imwrite(&*name, &image, &Vector::new()).cv_with(|| format!("writing {name}"))?;
    if !written {
        return Err(VisionError::BadFile {
            path: path.to_owned(),
            what: "could not be written as PNG".into(),
        });
    }
    Ok(())
}

/// Reads a greyscale PFM written by [`write_disparity`] (or Middlebury's tools); +∞ becomes
/// invalid.
pub fn read_pfm(path: &Path) -> Result<DisparityMap, VisionError> {
    let bytes = std::fs::read(path).map_err(|source| VisionError::Io { path: path.to_owned(), source })?;
    let bad = |what: &str| VisionError::BadFile { path: path.to_owned(), what: what.into() };
    let mut fields = Vec::new();
    let mut start = 0;
    for (i, b) in bytes.iter().enumerate() {
        if b.is_ascii_whitespace() {
            if i > start {
                fields.push(std::str::from_utf8(&bytes[start..i]).map_err(|_| bad("header is not text"))?);
            }
            start = i + 1;
            if fields.len() == 4 {
                break;
            }
        }
    }
    let [kind, w, h, scale] = fields[..] else { return Err(bad("truncated PFM header")) };
    if kind != "Pf" {
        return Err(bad("not a greyscale PFM (expected 'Pf')"));
    }
    let (width, height): (usize, usize) =
        (w.parse().map_err(|_| bad("bad width"))?, h.parse().map_err(|_| bad("bad height"))?);
    let little = scale.parse::<f32>().map_err(|_| bad("bad scale"))? < 0.0;
    let body = &bytes[start..];
    if width.checked_mul(height).and_then(|n| n.checked_mul(4)) != Some(body.len()) {
        return Err(bad("pixel data does not match the header's size"));
    }
    let mut values = vec![0.0; width * height];
    for (i, chunk) in body.chunks_exact(4).enumerate() {
        let raw = [chunk[0], chunk[1], chunk[2], chunk[3]];
        let v = if little { f32::from_le_bytes(raw) } else { f32::from_be_bytes(raw) };
        let (row, col) = (height - 1 - i / width, i % width);
        values[row * width + col] = if v.is_finite() { v } else { f32::NAN };
    }
    Ok(DisparityMap { width, height, values })
}
