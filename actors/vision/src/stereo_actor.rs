//! The stereo actor: takes the newest [`StereoFrame`] on `stereo_frame` (wire it through a
//! `latest` mailbox so stale frames are skipped, never queued) and publishes its
//! [`DepthGrid`] on `depth_grid`.
//!
//! The pipeline (~20–30 ms per VGA frame) runs on tokio's blocking pool, one frame in flight.
//! When the grid is published depends on `latency_s`:
//!
//! * **Unset** (a companion computer on hardware): as soon as the pipeline is done. Under
//!   lockstep the frame's work token is held until then, so simulated time stands still while
//!   the matcher runs, and the simulator, the renderer and the matcher never overlap. The
//!   handler awaits, so other work of the same instant may run first: simulated lockstep
//!   flights set `latency_s`.
//! * **Set** (the simulated vehicle): the companion computer's processing time is a fixed
//!   latency on the graph clock, as the camera's `latency_s` is. A frame handled at `t` starts
//!   at once on the blocking pool and its handler returns, so the graph (simulator, camera
//!   render, estimator, controller) runs on while the matcher works; the grid is published on
//!   the first `deliver` tick (every [`DELIVERY_TICK`]) at or after `t + latency_s`, and only
//!   that tick waits for a pipeline that is still running, blocking the thread so that neither
//!   simulated time nor that instant's other work can pass it. The same grids come out at the
//!   same simulated times, in the same order among that instant's messages, however fast the
//!   host is. A frame that arrives while one is in flight waits (the newest replaces an older
//!   waiting one, as the `latest` mailbox would) and starts when the grid before it is out.
//!
//! Each frame is first checked for a camera that delivers on time but no longer sees
//! ([`FrameCheck`]: dark, one lens capped, saturated, glare over the centre, the lenses' brightness
//! apart, or frozen while the vehicle moves, which it learns from the optional `nav_state`
//! input). Such a frame gives no grid, so the avoider's input goes stale and the
//! commander holds and then lands as for frames that stopped; the actor says so in the log on
//! each change and in its once-a-second `health` report ([`SensorHealth`], whose errors the
//! link turns into a STATUSTEXT naming the fault).

use std::time::Duration;

use kestrel_proto::messages::{DepthGrid, NavState, SensorHealth, StereoFrame};
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup, Time};
use serde::Deserialize;
use tokio::task::JoinHandle;

use crate::camera_actor::actor_error;
use crate::error::VisionError;
use crate::frame_check::{FrameCheck, FrameCheckParams, FrameFault};
use crate::pipeline::{Geometry, PipelineParams, StereoPipeline};

/// Period of the `deliver` timer that publishes grids under a configured `latency_s`: the
/// latency is rounded up to a multiple of it (the simulator's IMU runs at 400 Hz, so these
/// instants are already steps of the lockstep clock).
pub const DELIVERY_TICK: Duration = Duration::from_millis(5);

/// Longest processing latency accepted (s).
const MAX_LATENCY_S: f64 = 1.0;

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
    /// The companion computer's frame → grid time on the graph clock (s), in (0, 1]: a frame
    /// handled at `t` gives its grid at the first `deliver` tick at or after `t + latency_s`.
    /// Unset, the grid is published when the pipeline is done (see the module doc).
    #[serde(default)]
    pub latency_s: Option<f64>,
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
    /// Timer `deliver`, every [`DELIVERY_TICK`] (only with `latency_s`).
    Deliver(Time),
}

/// Frame → depth grid; ports `stereo_frame`, `nav_state` (inputs), `depth_grid`, `health`
/// (outputs).
pub struct StereoActor {
    /// The frame check, the matcher and their buffers; lent to the blocking pool while a frame
    /// is processed (comparing and copying a VGA pair is CPU work too).
    worker: Option<Worker>,
    /// `latency_s` in µs, if set.
    latency_us: Option<u64>,
    /// The frame on the blocking pool and when its grid is due (with `latency_s`).
    in_flight: Option<InFlight>,
    /// The newest frame that came while another was in flight (with `latency_s`).
    waiting: Option<StereoFrame>,
    /// The newest motion heard, handed to the frame check with the next frame.
    motion: Option<([f64; 3], [f64; 3])>,
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

/// What a job on the blocking pool gives back: the worker, the frame, its fault and, for a
/// frame without one, the pipeline's result.
type Done = (Worker, StereoFrame, Option<FrameFault>, Option<Result<DepthGrid, VisionError>>);

/// A frame on the blocking pool: its result comes back on `done` (the job's panic drops the
/// sender), and `handle` says when it has (for the awaiting path).
struct Job {
    done: std::sync::mpsc::Receiver<Done>,
    handle: JoinHandle<()>,
}

/// A frame being processed under `latency_s`.
struct InFlight {
    /// Publish at the first `deliver` tick at or after this time.
    due: Time,
    job: Job,
}

impl Actor for StereoActor {
    type Params = StereoParams;
    type Input = StereoInput;

    fn build(params: &StereoParams, setup: &mut impl Setup<StereoInput>) -> Result<Self, ActorError> {
        let pipeline = StereoPipeline::new(&params.geometry, &params.pipeline, setup.config_dir())
            .map_err(actor_error)?;
        params.frame_check.validate().map_err(actor_error)?;
        if let Some(latency) = params.latency_s
            && !(latency.is_finite() && latency > 0.0 && latency <= MAX_LATENCY_S)
        {
            return Err(ActorError::Params(format!(
                "latency_s must be in (0, {MAX_LATENCY_S}] s, got {latency}"
            )));
        }
        setup.input("stereo_frame", StereoInput::Frame);
        setup.input("nav_state", |n: NavState| {
            StereoInput::Motion(n.velocity_ned_m_s, n.angular_velocity_rad_s)
        });
        setup.timer("health_report", Duration::from_secs(1), StereoInput::Health);
        if params.latency_s.is_some() {
            setup.timer("deliver", DELIVERY_TICK, StereoInput::Deliver);
        }
        Ok(StereoActor {
            worker: Some(Worker { check: FrameCheck::new(params.frame_check.clone()), pipeline }),
            latency_us: params.latency_s.map(|s| (s * 1e6).round() as u64),
            in_flight: None,
            waiting: None,
            motion: None,
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
            StereoInput::Frame(frame) => match self.latency_us {
                None => {
                    let job = self.start(frame)?;
                    self.finish(job).await
                }
                Some(latency_us) if self.in_flight.is_none() => {
                    let job = self.start(frame)?;
                    self.in_flight =
                        Some(InFlight { due: Time(ctx.now().0.saturating_add(latency_us)), job });
                    Ok(())
                }
                Some(_) => {
                    self.waiting = Some(frame);
                    Ok(())
                }
            },
            StereoInput::Motion(velocity_m_s, rate_rad_s) => {
                self.motion = Some((velocity_m_s, rate_rad_s));
                Ok(())
            }
            StereoInput::Health(now) => {
                self.report(ctx, now);
                Ok(())
            }
            StereoInput::Deliver(now) => self.deliver(now),
        }
    }
}

impl StereoActor {
    /// Lends the worker to tokio's blocking pool for `frame` (the frame check, then the
    /// pipeline), so tens of milliseconds of matching never hold an async worker. A panic in
    /// the matcher comes back as an error when the job is awaited or its result waited for
    /// (the panic drops the result's sender), and the supervisor restarts this actor with a
    /// fresh pipeline.
    fn start(&mut self, frame: StereoFrame) -> Result<Job, ActorError> {
        let mut worker = self
            .worker
            .take()
            .ok_or_else(|| ActorError::Failed("stereo pipeline lost by an earlier panic".into()))?;
        let motion = self.motion;
        let (sender, done) = std::sync::mpsc::sync_channel(1);
        let handle = tokio::task::spawn_blocking(move || {
            if let Some((velocity_m_s, rate_rad_s)) = motion {
                worker.check.on_motion(velocity_m_s, rate_rad_s);
            }
            let fault = worker.check.check(&frame);
            let result = fault.is_none().then(|| worker.pipeline.process(&frame));
            // The receiver is gone only if the actor is: nobody wants the grid then.
            let _ = sender.send((worker, frame, fault, result));
        });
        Ok(Job { done, handle })
    }

    /// With `latency_s`: publishes the frame in flight once its grid is due by `now`, then
    /// starts the frame waiting, if any.
    ///
    /// A pipeline still running at the due tick is waited for by blocking this thread, not by
    /// awaiting: an await would let the other actors' work at the same simulated instant run
    /// first, so whether the avoider took the grid before or after, say, the commander's new
    /// setpoint would depend on how fast the host matched, and no two lockstep flights were
    /// alike (three idle runs of the same RTL flight ended 83.4, 82.0 and 150 s in). Blocking
    /// keeps the order the one of a pipeline that was done in time. Simulated time cannot pass
    /// the tick meanwhile either way; only the other work of that one instant waits.
    fn deliver(&mut self, now: Time) -> Result<(), ActorError> {
        let Some(flight) = self.in_flight.take_if(|f| f.due <= now) else {
            return Ok(());
        };
        let done = flight
            .job
            .done
            .recv()
            .map_err(|_| ActorError::Failed("stereo worker failed: it panicked".into()))?;
        self.publish(done)?;
        if let (Some(frame), Some(latency_us)) = (self.waiting.take(), self.latency_us) {
            let job = self.start(frame)?;
            self.in_flight = Some(InFlight { due: Time(now.0.saturating_add(latency_us)), job });
        }
        Ok(())
    }

    /// Awaits `job`, then publishes what it gave ([`StereoActor::publish`]).
    async fn finish(&mut self, job: Job) -> Result<(), ActorError> {
        job.handle.await.map_err(|e| ActorError::Failed(format!("stereo worker failed: {e}")))?;
        let done = job
            .done
            .try_recv()
            .map_err(|_| ActorError::Failed("stereo worker ended without a result".into()))?;
        self.publish(done)
    }

    /// Takes the worker back and publishes the grid, or counts and logs why there is none.
    fn publish(&mut self, (worker, frame, fault, result): Done) -> Result<(), ActorError> {
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
        assert_eq!(health[0].device, "stereo camera: camera_blind: dark");
    }

    /// The simulated companion computer: with `latency_s`, a frame handled at `t` gives its
    /// grid on the first `deliver` tick at or after `t + latency_s`, not before, stamped with
    /// the frame's capture time; the frame that came meanwhile follows a latency later.
    #[test]
    fn with_a_latency_the_grid_comes_out_on_the_first_tick_after_it() {
        let mut setup = TestSetup::new("stereo", ".");
        let params: StereoParams = serde_json::from_str(
            r#"{"geometry": {"rectified": {"focal_px": 224.07, "cx_px": 319.5, "cy_px": 239.5, "baseline_m": 0.12}}, "latency_s": 0.03}"#,
        )
        .expect("params");
        let mut actor = StereoActor::build(&params, &mut setup).expect("build");
        assert!(setup.timers().contains(&("deliver", DELIVERY_TICK)), "{:?}", setup.timers());
        let ctx = setup.context();
        let runtime = tokio::runtime::Builder::new_current_thread().build().expect("runtime");
        let mut seed = 7u32;
        let noise: Vec<u8> = (0..640 * 480)
            .map(|_| {
                seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                (seed >> 24) as u8
            })
            .collect();
        let frame = |k: u64| {
            StereoFrame::new(
                Time::from_micros(60_000 + 50_000 * k),
                k,
                640,
                480,
                noise.clone(),
                noise.clone(),
            )
            .expect("frame")
        };
        let mut at = |t_us: u64, input: StereoInput| {
            setup.manual_clock().set(Time::from_micros(t_us));
            runtime.block_on(actor.handle(&ctx, input)).expect("handled");
            setup.published::<DepthGrid>("depth_grid").iter().map(|g| g.time.0).collect::<Vec<_>>()
        };
        assert!(at(100_000, setup.input("stereo_frame", frame(0))).is_empty());
        assert!(at(110_000, setup.input("stereo_frame", frame(1))).is_empty(), "frame 1 waits");
        assert!(at(125_000, setup.tick("deliver", Time::from_micros(125_000))).is_empty(), "not due yet");
        assert_eq!(at(130_000, setup.tick("deliver", Time::from_micros(130_000))), [60_000]);
        assert_eq!(
            at(155_000, setup.tick("deliver", Time::from_micros(155_000))),
            [60_000],
            "frame 1 started at 130 ms"
        );
        assert_eq!(at(160_000, setup.tick("deliver", Time::from_micros(160_000))), [60_000, 110_000]);
    }
}
