//! The stereo actor: takes the newest [`StereoFrame`] on `stereo_frame` (wire it through a
//! `latest` mailbox so stale frames are skipped, never queued) and publishes its
//! [`DepthGrid`] on `depth_grid`.
//!
//! The pipeline (~20–30 ms per VGA frame) runs on tokio's blocking pool, one frame in flight;
//! under lockstep the frame's work token is held until the grid is published, so runs stay
//! deterministic.
//!
//! Each frame is first checked for a camera that delivers on time but no longer sees
//! ([`FrameCheck`]: black, or frozen while the vehicle moves, which it learns from the optional
//! `nav_state` input). Such a frame gives no grid, so the avoider's input goes stale and the
//! commander holds and then lands as for frames that stopped; the actor says so in the log on
//! each change and in its once-a-second `health` report ([`SensorHealth`], whose errors the
//! link turns into a STATUSTEXT naming the fault).

use std::time::Duration;

use kestrel_proto::messages::{DepthGrid, NavState, SensorHealth, StereoFrame};
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup, Time};
use serde::Deserialize;

use crate::camera_actor::actor_error;
use crate::error::VisionError;
use crate::frame_check::{FrameCheck, FrameCheckParams, FrameFault};
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
    #[serde(default)]
    pub frame_check: FrameCheckParams,
}

/// What the stereo actor handles.
#[derive(Debug)]
pub enum StereoInput {
    Frame(StereoFrame),
    /// The vehicle's motion from its NavState, for the frozen-frame check: velocity (NED, m/s)
    /// and body rate (FRD, rad/s).
    Motion([f64; 3], [f64; 3]),
    /// Timer `health_report`, every second.
    Health(Time),
}

/// Frame → depth grid; ports `stereo_frame`, `nav_state` (inputs), `depth_grid`, `health`
/// (outputs).
pub struct StereoActor {
    /// The frame check, the matcher and their buffers; lent to the blocking pool while a frame
    /// is processed (comparing and copying a VGA pair is CPU work too).
    worker: Option<Worker>,
    out: Publisher<DepthGrid>,
    health_out: Publisher<SensorHealth>,
    /// The fault of the newest frame, to log each change once.
    fault: Option<FrameFault>,
    /// Frames that could not be used (no pixels, wrong size, or a camera fault), for the logs.
    rejected: u64,
    /// Grids published and frames refused since the last health report.
    window: (u64, u64),
    window_start: Time,
}

/// What runs on the blocking pool for each frame.
struct Worker {
    check: FrameCheck,
    pipeline: StereoPipeline,
}

impl Actor for StereoActor {
    type Params = StereoParams;
    type Input = StereoInput;

    fn build(params: &StereoParams, setup: &mut impl Setup<StereoInput>) -> Result<Self, ActorError> {
        let pipeline = StereoPipeline::new(&params.geometry, &params.pipeline, setup.config_dir())
            .map_err(actor_error)?;
        params.frame_check.validate().map_err(actor_error)?;
        setup.input("stereo_frame", StereoInput::Frame);
        setup.input("nav_state", |n: NavState| {
            StereoInput::Motion(n.velocity_ned_m_s, n.angular_velocity_rad_s)
        });
        setup.timer("health_report", Duration::from_secs(1), StereoInput::Health);
        Ok(StereoActor {
            worker: Some(Worker { check: FrameCheck::new(params.frame_check.clone()), pipeline }),
            out: setup.output("depth_grid"),
            health_out: setup.output("health"),
            fault: None,
            rejected: 0,
            window: (0, 0),
            window_start: setup.clock().now(),
        })
    }

    async fn handle(&mut self, ctx: &Context, input: StereoInput) -> Result<(), ActorError> {
        match input {
            StereoInput::Frame(frame) => self.on_frame(frame).await,
            StereoInput::Motion(velocity_m_s, rate_rad_s) => {
                if let Some(worker) = &mut self.worker {
                    worker.check.on_motion(velocity_m_s, rate_rad_s);
                }
                Ok(())
            }
            StereoInput::Health(now) => {
                self.report(ctx, now);
                Ok(())
            }
        }
    }
}

impl StereoActor {
    /// Runs the frame check and the pipeline on tokio's blocking pool, so tens of milliseconds of matching never
    /// hold an async worker; awaiting it keeps one frame in flight, and the `latest` mailbox
    /// means the next frame is the newest. A panic in the matcher comes back as an error, and
    /// the supervisor restarts this actor with a fresh pipeline.
    async fn on_frame(&mut self, frame: StereoFrame) -> Result<(), ActorError> {
        let mut worker = self
            .worker
            .take()
            .ok_or_else(|| ActorError::Failed("stereo pipeline lost by an earlier panic".into()))?;
        let (worker, frame, fault, result) = tokio::task::spawn_blocking(move || {
            let fault = worker.check.check(&frame);
            let result = fault.is_none().then(|| worker.pipeline.process(&frame));
            (worker, frame, fault, result)
        })
        .await
        .map_err(|e| ActorError::Failed(format!("stereo worker failed: {e}")))?;
        self.worker = Some(worker);
        if fault != self.fault {
            match fault {
                Some(f) => {
                    tracing::warn!(frame = frame.sequence, "stereo camera {}: no depth grid", f.describe())
                }
                None => tracing::info!(frame = frame.sequence, "stereo camera frames usable again"),
            }
            self.fault = fault;
        }
        let Some(result) = result else {
            self.rejected += 1;
            self.window.1 += 1;
            return Ok(());
        };
        match result {
            Ok(grid) => {
                self.out.publish(grid);
                self.window.0 += 1;
                Ok(())
            }
            // A bad frame is skipped and counted; restarting would not make it better.
            Err(VisionError::Input(why)) => {
                self.rejected += 1;
                self.window.1 += 1;
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

    /// The last second's grids and refused frames, naming the camera fault if there is one.
    fn report(&mut self, ctx: &Context, now: Time) {
        let span_s = (now.as_secs_f64() - self.window_start.as_secs_f64()).max(1e-3);
        let (grids, refused) = std::mem::take(&mut self.window);
        let device = match self.fault {
            Some(f) => format!("stereo camera: {}", f.describe()),
            None => "stereo camera".to_owned(),
        };
        self.health_out.publish(SensorHealth {
            time: now,
            sensor: ctx.name().to_owned(),
            device,
            rate_hz: grids as f64 / span_s,
            errors: refused,
            errors_total: self.rejected,
            clipped: 0,
        });
        self.window_start = now;
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::testing::{TestSetup, ready};

    use super::*;

    /// A lens cap: frames keep coming, none gives a grid, and the health report names the fault
    /// for the link's STATUSTEXT.
    #[test]
    fn black_frames_give_no_grid_and_the_health_report_names_them() {
        let mut setup = TestSetup::new("stereo", ".");
        let params: StereoParams = serde_json::from_str(
            r#"{"geometry": {"rectified": {"focal_px": 224.07, "cx_px": 319.5, "cy_px": 239.5, "baseline_m": 0.12}}}"#,
        )
        .expect("params");
        let mut actor = StereoActor::build(&params, &mut setup).expect("build");
        let ctx = setup.context();
        let runtime = tokio::runtime::Builder::new_current_thread().build().expect("runtime");
        for k in 0..10u64 {
            let black = vec![0u8; 640 * 480];
            let frame = StereoFrame::new(Time::from_micros(50_000 * k), k, 640, 480, black.clone(), black)
                .expect("frame");
            runtime.block_on(actor.handle(&ctx, setup.input("stereo_frame", frame))).expect("frame handled");
        }
        ready(actor.handle(&ctx, setup.tick("health_report", Time::from_micros(1_000_000)))).expect("health");
        assert!(setup.published::<DepthGrid>("depth_grid").is_empty());
        let health: Vec<SensorHealth> = setup.published("health");
        assert_eq!(health.len(), 1);
        assert_eq!((health[0].errors, health[0].rate_hz), (10, 0.0));
        assert_eq!(health[0].device, "stereo camera: frames black");
    }
}
