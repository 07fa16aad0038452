//! Kestrel's stereo vision on OpenCV (thesis §1.3, §3.2, §3.3.1–3.3.3): chessboard stereo
//! calibration, rectification, semi-global block matching, depth `Z = B·f/d`, and the 3×3
//! depth grid the obstacle avoider reads.
//!
//! The pure core ([`calibration`], [`rectify`], [`matcher`], [`depth`], [`grid`], driven
//! together by [`StereoPipeline`]) is synchronous and deterministic; [`CameraActor`] and
//! [`StereoActor`] are the thin actor shells. [`calibrate()`] and [`disparity()`] are the
//! CLI's entry points.

pub mod board;
pub mod calibrate;
pub mod calibration;
mod calibration_file;
pub mod camera_actor;
pub mod camera_source;
pub mod depth;
pub mod depth_image;
pub mod disparity;
pub mod disparity_file;
pub mod disparity_map;
pub mod error;
pub mod frame_check;
pub mod glob;
pub mod grid;
pub mod image;
pub mod mat;
pub mod matcher;
pub mod pipeline;
pub mod rectify;
pub mod score;
pub mod stereo_actor;
pub mod texture;

pub use board::Board;
pub use calibrate::{CalibrationReport, SkippedPair, UsedPair, calibrate};
pub use calibration::{StereoCalibration, depth_scale_from_references};
pub use camera_actor::{CameraActor, CameraParams};
pub use camera_source::{FrameSource, SourceParams};
pub use depth::{DepthMap, StereoGeometry};
pub use depth_image::{DepthRange, colourise, write_depth_png};
pub use disparity::{DisparityReport, disparity};
pub use disparity_map::DisparityMap;
pub use error::VisionError;
pub use grid::{DepthGridder, GridParams, depth_grid};
pub use kestrel_proto::messages::StereoFrame;
pub use matcher::{BmParams, Matcher, MatcherParams, SgbmMode, SgbmParams};
pub use pipeline::{Geometry, PipelineParams, StageTimes, StereoPipeline};
pub use rectify::Rectifier;
pub use score::{DisparityScores, GroundTruth, score};
pub use stereo_actor::{StereoActor, StereoInput, StereoParams};
pub use texture::TextureParams;
