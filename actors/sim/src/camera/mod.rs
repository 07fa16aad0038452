//! The simulated stereo camera: a ZED-like rectified pair rendered by ray casting against the
//! world (flat ground, boxes, cylinders, walls) from the vehicle's true pose, with procedural
//! texture so block matching has something to match, and the true depth of every left pixel
//! for scoring.
//!
//! [`StereoCameraParams`] configure the rig, [`Scene`] holds the world in renderer form and
//! [`StereoCamera::render`] (a body at rest) or [`StereoCamera::render_moving`] (a body in
//! motion, for motion blur) makes a [`StereoRender`]: left and right 8-bit grey images and a
//! [`DepthImage`]. Motion blur, auto-exposure gain changes, a left/right gain mismatch and
//! pixel noise are optional and off by default. The core is pure;
//! [`CameraSimActor`](crate::CameraSimActor) publishes it.

mod params;
mod raycast;
#[cfg(any(test, feature = "render-reference"))]
pub mod reference;
mod render;
mod scene;
mod texture;

pub use params::{Intrinsics, StereoCameraParams};
pub use render::{CapturePose, DepthImage, RenderBuffers, StereoCamera, StereoRender};
pub use scene::Scene;
