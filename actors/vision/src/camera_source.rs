//! Where stereo frames come from: a side-by-side V4L2/UVC camera (the ZED's format), a pair of
//! video files, or a folder of image pairs. Reads block; the camera actor calls them.

use std::path::{Path, PathBuf};

use opencv::core::{Mat, MatTraitConst, Rect};
use opencv::prelude::*;
use opencv::videoio::{self, VideoCapture};
use serde::{Deserialize, Serialize};

use crate::error::{CvContext, VisionError};
use crate::glob;
use crate::image::{load_gray, to_gray};

/// A frame source, from the camera actor's `source` parameter table (`kind = "…"`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum SourceParams {
    /// A V4L2 camera (`/dev/video{device}`) delivering left and right side by side in one
    /// `width`×`height` frame, as the ZED does (e.g. 2560×720 for two 1280×720 views).
    SideBySide { device: u32, width: u32, height: u32, fps: f64 },
    /// Two synchronised video files, one per camera.
    VideoPair { left: PathBuf, right: PathBuf },
    /// Image pairs in a folder: files matching `left` and `right` (`*`, `?` wildcards), paired
    /// in sorted name order; with `repeat`, start over after the last pair.
    ImageFolder {
        dir: PathBuf,
        left: String,
        right: String,
        #[serde(default)]
        repeat: bool,
    },
}

enum Kind {
    SideBySide(VideoCapture),
    VideoPair(VideoCapture, VideoCapture),
    Images { pairs: Vec<(PathBuf, PathBuf)>, next: usize, repeat: bool },
}

/// An open frame source.
pub struct FrameSource {
    kind: Kind,
    name: String,
    frame: Mat,
    second: Mat,
}

fn open_video(path: &Path) -> Result<VideoCapture, VisionError> {
    if !path.is_file() {
        return Err(VisionError::BadFile { path: path.to_owned(), what: "no such video file".into() });
    }
    let capture =
        VideoCapture::from_file(path, videoio::CAP_ANY).cv_with(|| format!("opening {}", path.display()))?;
    if !capture.is_opened().cv("video open")? {
        return Err(VisionError::BadFile { path: path.to_owned(), what: "not a readable video".into() });
    }
    Ok(capture)
}

impl FrameSource {
    /// Opens the source; relative paths resolve against `base_dir`.
    pub fn open(params: &SourceParams, base_dir: &Path) -> Result<FrameSource, VisionError> {
        let (kind, name) = match params {
            SourceParams::SideBySide { device, width, height, fps } => {
                if *width < 2 || width % 2 != 0 || *height == 0 || !(fps.is_finite() && *fps > 0.0) {
                    return Err(VisionError::Params(format!(
                        "side-by-side camera needs an even width, a height and a positive fps, got {width}×{height} at {fps}"
                    )));
                }
                let index =
                    i32::try_from(*device).map_err(|_| VisionError::Params(format!("device {device}")))?;
                let mut capture = VideoCapture::new(index, videoio::CAP_V4L2)
                    .cv_with(|| format!("opening /dev/video{device}"))?;
                if !capture.is_opened().cv("camera open")? {
                    return Err(VisionError::Input(format!(
                        "/dev/video{device} cannot be opened as a V4L2 camera"
                    )));
                }
                capture.set(videoio::CAP_PROP_FRAME_WIDTH, f64::from(*width)).cv("camera width")?;
                capture.set(videoio::CAP_PROP_FRAME_HEIGHT, f64::from(*height)).cv("camera height")?;
                capture.set(videoio::CAP_PROP_FPS, *fps).cv("camera fps")?;
                (Kind::SideBySide(capture), format!("/dev/video{device}"))
            }
            SourceParams::VideoPair { left, right } => {
                let (l, r) = (base_dir.join(left), base_dir.join(right));
                (
                    Kind::VideoPair(open_video(&l)?, open_video(&r)?),
                    format!("{} + {}", l.display(), r.display()),
                )
            }
            SourceParams::ImageFolder { dir, left, right, repeat } => {
                let dir = base_dir.join(dir);
                let pattern = |p: &str| dir.join(p).to_string_lossy().into_owned();
                let (l, r) = (glob::expand(&pattern(left))?, glob::expand(&pattern(right))?);
                if l.is_empty() || l.len() != r.len() {
                    return Err(VisionError::Params(format!(
                        "{}: {} files match '{left}' and {} match '{right}'; need the same non-zero number",
                        dir.display(),
                        l.len(),
                        r.len()
                    )));
                }
                (
                    Kind::Images { pairs: l.into_iter().zip(r).collect(), next: 0, repeat: *repeat },
                    dir.display().to_string(),
                )
            }
        };
        Ok(FrameSource { kind, name, frame: Mat::default(), second: Mat::default() })
    }

    /// What the source reads, for logs.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The next pair as 8-bit grey images, `None` once the source is exhausted.
    pub fn next_pair(&mut self) -> Result<Option<(Mat, Mat)>, VisionError> {
        match &mut self.kind {
            Kind::SideBySide(capture) => {
                if !capture.read(&mut self.frame).cv("camera read")? || self.frame.empty() {
                    return Err(VisionError::Input(format!("{}: camera delivered no frame", self.name)));
                }
                let (w, h) = (self.frame.cols() / 2, self.frame.rows());
                let half = |x| -> Result<Mat, VisionError> {
                    to_gray(
                        &Mat::roi(&self.frame, Rect::new(x, 0, w, h))
                            .cv("frame half")?
                            .try_clone()
                            .cv("frame half")?,
                    )
                };
                Ok(Some((half(0)?, half(w)?)))
            }
            Kind::VideoPair(left, right) => {
                // Grab both before decoding either, so the two exposures are as close as possible.
                let (l, r) = (left.grab().cv("left video grab")?, right.grab().cv("right video grab")?);
                if !(l && r) {
                    return Ok(None);
                }
                left.retrieve(&mut self.frame, 0).cv("left video frame")?;
                right.retrieve(&mut self.second, 0).cv("right video frame")?;
                Ok(Some((to_gray(&self.frame)?, to_gray(&self.second)?)))
            }
            Kind::Images { pairs, next, repeat } => {
                if *next == pairs.len() {
                    if !*repeat {
                        return Ok(None);
                    }
                    *next = 0;
                }
                let (l, r) = &pairs[*next];
                *next += 1;
                Ok(Some((load_gray(l)?, load_gray(r)?)))
            }
        }
    }
}
