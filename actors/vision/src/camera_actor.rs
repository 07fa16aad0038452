//! The camera actor: reads a [`FrameSource`] at a fixed rate and publishes each pair as a
//! [`StereoFrame`] on `stereo_frame`, stamped with its capture time.
//!
//! Reads block the actor's task for one frame's I/O (a few ms); that is acceptable for a
//! source actor and keeps the shell free of threads of its own.

use kestrel_proto::messages::StereoFrame;
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup, Time};
use opencv::core::MatTraitConst;
use serde::Deserialize;

use crate::camera_source::{FrameSource, SourceParams};
use crate::error::VisionError;
use crate::image::gray_bytes;

/// Parameters of [`CameraActor`].
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraParams {
    pub source: SourceParams,
    /// Frames read per second (Hz), on the graph clock.
    pub fps: f64,
}

/// Publishes stereo frames; port `stereo_frame` (output), timer `frame`.
pub struct CameraActor {
    source: FrameSource,
    out: Publisher<StereoFrame>,
    sequence: u64,
    exhausted: bool,
}

/// Maps a vision error to the supervisor's vocabulary.
pub(crate) fn actor_error(e: VisionError) -> ActorError {
    match e {
        VisionError::Params(m) => ActorError::Params(m),
        other => ActorError::Failed(other.to_string()),
    }
}

impl Actor for CameraActor {
    type Params = CameraParams;
    type Input = Time;

    fn build(params: &CameraParams, setup: &mut impl Setup<Time>) -> Result<Self, ActorError> {
        let period = kestrel_proto::timing::period_of_rate("fps", params.fps, 0.0, 1000.0)?;
        let source = FrameSource::open(&params.source, setup.config_dir()).map_err(actor_error)?;
        setup.timer("frame", period, |t| t);
        Ok(CameraActor { source, out: setup.output("stereo_frame"), sequence: 0, exhausted: false })
    }

    async fn handle(&mut self, ctx: &Context, _tick: Time) -> Result<(), ActorError> {
        if self.exhausted {
            return Ok(());
        }
        let Some((left, right)) = self.source.next_pair().map_err(actor_error)? else {
            tracing::info!(source = self.source.name(), frames = self.sequence, "stereo source exhausted");
            self.exhausted = true;
            return Ok(());
        };
        let captured = ctx.now();
        let (width, height) = (left.cols() as u32, left.rows() as u32);
        let frame = StereoFrame::new(
            captured,
            self.sequence,
            width,
            height,
            gray_bytes(&left).map_err(actor_error)?,
            gray_bytes(&right).map_err(actor_error)?,
        )
        .map_err(|e| actor_error(e.into()))?;
        self.sequence += 1;
        self.out.publish(frame);
        Ok(())
    }
}
