//! The stereo actor: takes the newest [`StereoFrame`] on `stereo_frame` (wire it through a
//! `latest` mailbox so stale frames are skipped, never queued) and publishes its
//! [`DepthGrid`] on `depth_grid`.
//!
//! The pipeline (~20–30 ms per VGA frame) runs on tokio's blocking pool, one frame in flight;
//! under lockstep the frame's work token is held until the grid is published, so runs stay
//! deterministic.

use kestrel_proto::messages::{DepthGrid, StereoFrame};
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup};
use serde::Deserialize;

use crate::camera_actor::actor_error;
use crate::error::VisionError;
use crate::pipeline::{Geometry, PipelineParams, StereoPipeline};

/// Parameters of [`StereoActor`].
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StereoParams {
    /// `{ calibration = "stereo.yaml" }` for raw frames, or `{ rectified = { focal_px, cx_px,
    /// cy_px, baseline_m } }` for frames that arrive rectified.
    pub geometry: Geometry,
    #[serde(default)]
    pub pipeline: PipelineParams,
}

/// Frame → depth grid; ports `stereo_frame` (input) and `depth_grid` (output).
pub struct StereoActor {
    /// The matcher and its buffers; lent to the blocking pool while a frame is processed.
    pipeline: Option<StereoPipeline>,
    out: Publisher<DepthGrid>,
    /// Frames that could not be used (no pixels, wrong size), for the logs.
    rejected: u64,
}

impl Actor for StereoActor {
    type Params = StereoParams;
    type Input = StereoFrame;

    fn build(params: &StereoParams, setup: &mut impl Setup<StereoFrame>) -> Result<Self, ActorError> {
        let pipeline = StereoPipeline::new(&params.geometry, &params.pipeline, setup.config_dir())
            .map_err(actor_error)?;
        setup.input("stereo_frame", |f| f);
        Ok(StereoActor { pipeline: Some(pipeline), out: setup.output("depth_grid"), rejected: 0 })
    }

    /// Runs the pipeline on tokio's blocking pool, so tens of milliseconds of matching never
    /// hold an async worker; awaiting it keeps one frame in flight, and the `latest` mailbox
    /// means the next frame is the newest. A panic in the matcher comes back as an error, and
    /// the supervisor restarts this actor with a fresh pipeline.
    async fn handle(&mut self, _ctx: &Context, frame: StereoFrame) -> Result<(), ActorError> {
        let mut pipeline = self
            .pipeline
            .take()
            .ok_or_else(|| ActorError::Failed("stereo pipeline lost by an earlier panic".into()))?;
        let (pipeline, frame, result) = tokio::task::spawn_blocking(move || {
            let result = pipeline.process(&frame);
            (pipeline, frame, result)
        })
        .await
        .map_err(|e| ActorError::Failed(format!("stereo worker failed: {e}")))?;
        self.pipeline = Some(pipeline);
        match result {
            Ok(grid) => {
                self.out.publish(grid);
                Ok(())
            }
            // A bad frame is skipped and counted; restarting would not make it better.
            Err(VisionError::Input(why)) => {
                self.rejected += 1;
                tracing::warn!(
                    frame = frame.sequence,
                    rejected = self.rejected,
                    "stereo frame skipped: {why}"
                );
                Ok(())
            }
            Err(e) => Err(actor_error(e)),
        }
    }
}
