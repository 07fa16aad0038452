//! The simulated stereo camera as an actor: renders the world from the simulator's ground
//! truth and publishes [`StereoFrame`]s on `stereo_frame`.
//!
//! Design choice: the camera is its own actor fed by the simulator's `ground_truth` output
//! (wire it through a `queue` mailbox so every sample arrives), not a timer inside
//! [`SimActor`](crate::SimActor). Everything is scheduled on the ground truth's own time
//! stamps, never on wall-clock time, so lockstep runs stay deterministic:
//!
//! * **Capture**: the first sample at or after each due time (every `1/rate_hz` from the first
//!   sample) is the frame's capture instant. Its pose, velocity and body rate (for motion blur)
//!   are taken and the render (`cargo bench -p kestrel-sim --bench render` times it) is
//!   started on tokio's blocking pool; the handler returns at once, so the simulator steps on
//!   while the pair renders (the two cameras on two threads, on a host with more than one
//!   CPU). The frame is stamped with the capture instant. The frame rate is quantised to the
//!   ground truth's (50 Hz by default): 15 Hz comes out as alternating 60 and 80 ms periods
//!   averaging 1/15 s.
//! * **Delivery**: the frame is published while handling the first sample whose time is at or
//!   after capture + `latency_s`, a real camera's exposure, readout and transfer delay. If the
//!   render has not finished by then, that handler awaits it. Under the lockstep clock a
//!   handler that awaits keeps its input's work token, so simulated time cannot pass the
//!   delivery sample until the frame is out (the simulator waits for the camera): the frame
//!   reaches its subscribers at the same simulated time, with the same pixels, however fast
//!   the host renders. With `latency_s = 0` the capture sample itself awaits its render, as an
//!   inline render would.
//! * **Frames in flight**: at most [`MAX_IN_FLIGHT`]. With the defaults (15 Hz, 40 ms) there is
//!   never more than one; a latency longer than the frame period pipelines renders, as a real
//!   camera overlaps exposure and readout. A capture that falls due while the pipeline is full
//!   is skipped (logged and counted, and as deterministic as the rest), as a camera drops a
//!   frame it has no buffer for, so a slow host or an extreme configuration never queues
//!   without bound.
//! * **Faults**: the world file's `camera_*` faults (`faults.rs`), by the capture instant:
//!   `camera_stop` skips the capture (nothing is published); `camera_black` publishes the frame
//!   on time with every pixel 0; `camera_frozen` publishes the pixels of the last frame before
//!   the fault with the new stamp and sequence number; `camera_glare` washes a region of one or
//!   both images towards white; `camera_capped` blacks out one image. The simulator actor logs
//!   and publishes their start and end (`sim_fault`); the camera only applies them. Camera
//!   faults the simulator adds while it runs (MAV_CMD_INJECT_FAILURE on the avoidance unit,
//!   `live_faults.rs`) come on the optional `sim_fault` input: each start beyond the world
//!   file's own faults joins the camera's schedule at its time, each end ends it (the camera and
//!   the simulator fly the same world, so the world's entries have the same indices in both).
//!   Held by `tests/camera_actor.rs` and, in flight, by `tests/gcs_camera_fault.rs`.

use std::collections::VecDeque;
use std::path::PathBuf;
use std::sync::Arc;

use kestrel_proto::messages::{GroundTruth, SimFault, SimFaultPhase, StereoFrame};
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup, Time};
use serde::Deserialize;
use tokio::task::JoinHandle;

use crate::camera::{
    CapturePose, DepthImage, RenderBuffers, Scene, StereoCamera, StereoCameraParams, StereoRender,
};
use crate::error::InvalidParam;
use crate::faults::{CameraFaults, FaultSchedule, fault_of_message};
use crate::world::World;

/// Renders started but not yet published, at most.
const MAX_IN_FLIGHT: usize = 4;

/// Longest capture-to-delivery latency accepted (s).
const MAX_LATENCY_S: f64 = 1.0;

/// `[actors.camera.params]` of a [`CameraSimActor`].
#[derive(Clone, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraSimParams {
    /// World file, relative to the config file's directory (the simulator's).
    pub world: PathBuf,
    /// Frame rate (Hz), in (0, 1000].
    pub rate_hz: f64,
    /// Capture-to-delivery latency (s), in [0, 1]: a frame captured at `t` is published with
    /// the first ground-truth sample at or after `t + latency_s`, stamped `t`. A USB stereo
    /// camera such as the ZED delivers a VGA pair some 30–60 ms after exposure.
    pub latency_s: f64,
    /// `[actors.camera.params.camera]`: the rig.
    pub camera: StereoCameraParams,
}

impl Default for CameraSimParams {
    fn default() -> CameraSimParams {
        CameraSimParams {
            world: PathBuf::from("worlds/empty.toml"),
            rate_hz: 15.0,
            latency_s: 0.04,
            camera: StereoCameraParams::default(),
        }
    }
}

impl CameraSimParams {
    /// Checks every field; the error names the offending one (`camera.…` for the rig's).
    pub fn validate(&self) -> Result<(), InvalidParam> {
        if !(self.rate_hz.is_finite() && self.rate_hz > 0.0 && self.rate_hz <= 1000.0) {
            return Err(InvalidParam::new("rate_hz", format!("must be in (0, 1000], got {}", self.rate_hz)));
        }
        if !(self.latency_s.is_finite() && (0.0..=MAX_LATENCY_S).contains(&self.latency_s)) {
            return Err(InvalidParam::new(
                "latency_s",
                format!("must be in [0, {MAX_LATENCY_S}] s, got {}", self.latency_s),
            ));
        }
        self.camera.validate().map_err(|e| e.within("camera"))
    }
}

/// A frame whose render is running (or done) on the blocking pool, waiting for its delivery
/// sample.
struct Pending {
    /// The capture instant: the frame's stamp.
    capture: Time,
    /// Publish with the first sample at or after this time.
    deliver_at: Time,
    sequence: u64,
    /// The camera faults active at capture.
    faults: CameraFaults,
    /// The render, and the working memory it borrowed, back when it is done.
    render: JoinHandle<(StereoRender, RenderBuffers)>,
}

/// What the camera actor handles: poses to render from, and the simulator's fault events.
#[derive(Debug)]
pub enum CameraInput {
    Truth(GroundTruth),
    Fault(SimFault),
}

/// Ground truth → rendered stereo frames; ports `ground_truth` and `sim_fault` (inputs) and
/// `stereo_frame` (output).
pub struct CameraSimActor {
    /// Shared, read-only, with the renders in flight.
    camera: Arc<StereoCamera>,
    scene: Arc<Scene>,
    rate_hz: f64,
    latency_us: u64,
    /// Time of the first sample: frame `k` is due `k/rate_hz` after it; `None` before it.
    origin: Option<Time>,
    /// Index of the next frame due.
    next_slot: u64,
    /// Sequence number of the next frame captured.
    sequence: u64,
    /// Oldest capture first.
    pending: VecDeque<Pending>,
    /// Captures skipped because [`MAX_IN_FLIGHT`] renders were pending.
    skipped: u64,
    /// Working memory of finished renders, lent to the next ones (at most [`MAX_IN_FLIGHT`]).
    spare: Vec<RenderBuffers>,
    /// True depth of the last published frame's left image.
    last_depth: Option<DepthImage>,
    /// The world's faults, then those the simulator added; only the camera's apply here.
    faults: FaultSchedule,
    /// How many faults the world file has: a `sim_fault` of a higher index was added live.
    world_faults: usize,
    /// The simulator's index of each live camera fault and its index in `faults`.
    live: Vec<(u32, usize)>,
    /// The last frame published healthy, which `camera_frozen` repeats.
    last_frame: Option<StereoFrame>,
    out: Publisher<StereoFrame>,
}

impl CameraSimActor {
    /// The rig, e.g. for the stereo actor's rectified geometry.
    pub fn camera(&self) -> &StereoCamera {
        &self.camera
    }

    /// True depth of the last published frame (for scoring), if any.
    pub fn last_depth(&self) -> Option<&DepthImage> {
        self.last_depth.as_ref()
    }

    /// Captures skipped because the render pipeline was full (four frames in flight).
    pub fn skipped(&self) -> u64 {
        self.skipped
    }

    /// When frame slot `slot` is due, counting from `origin` (rounded to the µs, without
    /// accumulating rounding error).
    fn due(&self, origin: Time, slot: u64) -> Time {
        Time(origin.0 + (slot as f64 * 1e6 / self.rate_hz).round() as u64)
    }

    /// Starts rendering the frame captured at `truth` on the blocking pool.
    fn capture(&mut self, truth: &GroundTruth) {
        let faults = self.faults.effects_at(truth.time).camera;
        if faults.stop {
            return;
        }
        if self.pending.len() >= MAX_IN_FLIGHT {
            self.skipped += 1;
            tracing::warn!(
                at = %truth.time,
                skipped = self.skipped,
                "camera capture skipped: {MAX_IN_FLIGHT} frames already in flight"
            );
            return;
        }
        let pose = CapturePose::from(truth);
        let (camera, scene, sequence) = (Arc::clone(&self.camera), Arc::clone(&self.scene), self.sequence);
        let mut buffers = self.spare.pop().unwrap_or_default();
        let render = tokio::task::spawn_blocking(move || {
            let render = camera.render_moving(&scene, &pose, sequence, &mut buffers);
            (render, buffers)
        });
        self.pending.push_back(Pending {
            capture: truth.time,
            deliver_at: Time(truth.time.0.saturating_add(self.latency_us)),
            sequence,
            faults,
            render,
        });
        self.sequence += 1;
    }

    /// Publishes every pending frame whose delivery time has come by `now`, oldest first,
    /// awaiting renders that are still running.
    async fn deliver(&mut self, now: Time) -> Result<(), ActorError> {
        while let Some(next) = self.pending.pop_front_if(|p| p.deliver_at <= now) {
            let (render, buffers) = next
                .render
                .await
                .map_err(|e| ActorError::Failed(format!("camera render {} failed: {e}", next.sequence)))?;
            self.spare.push(buffers);
            let (frame, depth) = render
                .into_frame(next.capture, next.sequence)
                .map_err(|e| ActorError::Failed(e.to_string()))?;
            let frame = self.apply_faults(frame, next.faults)?;
            self.out.publish(frame);
            self.last_depth = Some(depth);
        }
        Ok(())
    }
}

impl CameraSimActor {
    /// `frame` as the camera faults active at its capture leave it (stopped frames are never
    /// captured): black pixels, the last healthy frame's pixels under `frame`'s stamp, or
    /// `frame` with glare and a capped lens applied.
    fn apply_faults(&mut self, frame: StereoFrame, faults: CameraFaults) -> Result<StereoFrame, ActorError> {
        if faults.black {
            let pixels = frame.width as usize * frame.height as usize;
            return StereoFrame::new(
                frame.time,
                frame.sequence,
                frame.width,
                frame.height,
                vec![0; pixels],
                vec![0; pixels],
            )
            .map_err(|e| ActorError::Failed(e.to_string()));
        }
        if faults.frozen
            && let Some(last) = &self.last_frame
        {
            let mut repeated = last.clone();
            repeated.time = frame.time;
            repeated.sequence = frame.sequence;
            return Ok(repeated);
        }
        if faults.glare.is_none() && !faults.capped_left && !faults.capped_right {
            self.last_frame = Some(frame.clone());
            return Ok(frame);
        }
        let (width, height) = (frame.width as usize, frame.height as usize);
        let (mut left, mut right) = (frame.left().to_vec(), frame.right().to_vec());
        if let Some(glare) = faults.glare {
            glare.apply(&mut left, width, height, true);
            glare.apply(&mut right, width, height, false);
        }
        if faults.capped_left {
            left.fill(0);
        }
        if faults.capped_right {
            right.fill(0);
        }
        // The frame as rendered stays the last healthy one, which `camera_frozen` repeats.
        let faulty = StereoFrame::new(frame.time, frame.sequence, frame.width, frame.height, left, right)
            .map_err(|e| ActorError::Failed(e.to_string()))?;
        self.last_frame = Some(frame);
        Ok(faulty)
    }
}

impl CameraSimActor {
    /// A fault the simulator started or ended while running: camera kinds join (or leave) the
    /// schedule at the event's time; the world file's own faults are in it already.
    fn on_sim_fault(&mut self, event: &SimFault) -> Result<(), ActorError> {
        if (event.index as usize) < self.world_faults || !event.kind.starts_with("camera_") {
            return Ok(());
        }
        match event.phase {
            SimFaultPhase::Started => {
                let fault = fault_of_message(event).map_err(ActorError::Failed)?;
                self.faults.push(fault);
                self.live.push((event.index, self.faults.faults().len() - 1));
            }
            SimFaultPhase::Ended => {
                if let Some(&(_, at)) = self.live.iter().find(|(index, _)| *index == event.index) {
                    self.faults.end_after(at, Time(event.time.0.saturating_sub(1)));
                }
            }
        }
        Ok(())
    }

    /// Delivers what is due, captures if a frame is due, then delivers again so that a zero
    /// latency publishes the capture sample's own frame.
    async fn on_truth(&mut self, truth: GroundTruth) -> Result<(), ActorError> {
        self.deliver(truth.time).await?;
        let origin = *self.origin.get_or_insert(truth.time);
        if truth.time >= self.due(origin, self.next_slot) {
            self.capture(&truth);
            while self.due(origin, self.next_slot) <= truth.time {
                self.next_slot += 1;
            }
        }
        self.deliver(truth.time).await
    }
}

impl Actor for CameraSimActor {
    type Params = CameraSimParams;
    type Input = CameraInput;

    fn build(
        params: &CameraSimParams,
        setup: &mut impl Setup<CameraInput>,
    ) -> Result<CameraSimActor, ActorError> {
        params.validate().map_err(|e| ActorError::Params(e.to_string()))?;
        let camera = StereoCamera::new(&params.camera)
            .map_err(|e| ActorError::Params(e.within("camera").to_string()))?;
        let world = World::load(&setup.config_dir().join(&params.world))
            .map_err(|e| ActorError::Params(e.to_string()))?;
        setup.input("ground_truth", CameraInput::Truth);
        setup.input("sim_fault", CameraInput::Fault);
        Ok(CameraSimActor {
            camera: Arc::new(camera),
            scene: Arc::new(Scene::new(&world.obstacles)),
            rate_hz: params.rate_hz,
            latency_us: (params.latency_s * 1e6).round() as u64,
            origin: None,
            next_slot: 0,
            sequence: 0,
            pending: VecDeque::with_capacity(MAX_IN_FLIGHT),
            skipped: 0,
            spare: Vec::with_capacity(MAX_IN_FLIGHT),
            last_depth: None,
            faults: FaultSchedule::new(&world.faults),
            world_faults: world.faults.len(),
            live: Vec::new(),
            last_frame: None,
            out: setup.output("stereo_frame"),
        })
    }

    async fn handle(&mut self, _ctx: &Context, input: CameraInput) -> Result<(), ActorError> {
        match input {
            CameraInput::Truth(truth) => self.on_truth(truth).await,
            CameraInput::Fault(event) => self.on_sim_fault(&event),
        }
    }
}
