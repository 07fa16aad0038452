//! A stereo camera frame: both 8-bit grey images and their capture time.
//!
//! Frames travel between actors as a [`Message`](crate::Message) so a camera (real or
//! simulated) can feed the stereo actor through a `latest` mailbox, but their pixels are not
//! serialised: the recorder logs every message as JSON, where a VGA pair would cost ~1 MB per
//! frame (30 MB/s). A recorded frame holds its time, sequence number and size only; one read
//! back from a log has no pixels ([`StereoFrame::has_pixels`] is false) and the stereo actor
//! skips it.

use std::fmt;
use std::sync::Arc;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// Both images of one stereo capture.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema)]
pub struct StereoFrame {
    /// When the frame was captured (the grab's return on the graph clock).
    pub time: Time,
    /// Frame number at its source, from 0.
    pub sequence: u64,
    /// Image width (px).
    pub width: u32,
    /// Image height (px).
    pub height: u32,
    /// The pixels; shared, so fanning a frame out to several subscribers copies nothing.
    #[serde(skip)]
    pixels: FramePixels,
}
crate::impl_message!(StereoFrame);

/// Images whose sizes do not match the frame's width and height.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("frame {sequence}: {width}×{height} needs {} bytes per image, got {left_len} and {right_len}", *width as usize * *height as usize)]
pub struct FrameSizeError {
    /// The frame's sequence number.
    pub sequence: u64,
    /// Claimed width (px).
    pub width: u32,
    /// Claimed height (px).
    pub height: u32,
    /// Bytes in the left image.
    pub left_len: usize,
    /// Bytes in the right image.
    pub right_len: usize,
}

/// Left and right 8-bit grey images, row-major.
#[derive(Clone, Default)]
struct FramePixels {
    left: Arc<[u8]>,
    right: Arc<[u8]>,
}

impl fmt::Debug for FramePixels {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "FramePixels({} + {} bytes)", self.left.len(), self.right.len())
    }
}

impl StereoFrame {
    /// A frame of two `width`×`height` grey images (row-major, one byte per pixel); both must
    /// be non-empty and exactly that size.
    pub fn new(
        time: Time,
        sequence: u64,
        width: u32,
        height: u32,
        left: Vec<u8>,
        right: Vec<u8>,
    ) -> Result<StereoFrame, FrameSizeError> {
        let expected = width as usize * height as usize;
        if width == 0 || height == 0 || left.len() != expected || right.len() != expected {
            return Err(FrameSizeError {
                sequence,
                width,
                height,
                left_len: left.len(),
                right_len: right.len(),
            });
        }
        Ok(StereoFrame {
            time,
            sequence,
            width,
            height,
            pixels: FramePixels { left: left.into(), right: right.into() },
        })
    }

    /// Whether the frame carries its images (false for one read back from a log).
    pub fn has_pixels(&self) -> bool {
        !self.pixels.left.is_empty()
    }

    /// The left image, row-major (empty without pixels).
    pub fn left(&self) -> &[u8] {
        &self.pixels.left
    }

    /// The right image, row-major (empty without pixels).
    pub fn right(&self) -> &[u8] {
        &self.pixels.right
    }
}
