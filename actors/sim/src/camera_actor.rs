//! The simulated stereo camera as an actor: renders the world from the simulator's ground
//! truth and publishes [`StereoFrame`]s on `stereo_frame`.
//!
//! Design choice: the camera is its own actor fed by the simulator's `ground_truth` output
//! (wire it through a `queue` mailbox so every sample arrives), not a timer inside
//! [`SimActor`](crate::SimActor). Frames are scheduled on the ground truth's own time stamps:
//! the first sample at or after each due time (every `1/rate_hz`) is rendered and the frame is
//! stamped with that sample's time, the instant the pose was true. The images therefore depend
//! only on the ground-truth stream, never on wall-clock or scheduling, so lockstep runs stay
//! deterministic; the frame rate is quantised to the ground truth's (50 Hz by default), so
//! 15 Hz comes out as alternating 60 and 80 ms periods averaging 1/15 s. Rendering (~25 ms per
//! VGA pair) runs inside the handler on the actor's task.

use std::path::PathBuf;

use kestrel_proto::messages::{GroundTruth, StereoFrame};
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup, Time};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use serde::Deserialize;

use crate::camera::{DepthImage, Scene, StereoCamera, StereoCameraParams};
use crate::world::World;

/// `[actors.camera.params]` of a [`CameraSimActor`].
#[derive(Clone, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraSimParams {
    /// World file, relative to the config file's directory (the simulator's).
    pub world: PathBuf,
    /// Frame rate (Hz).
    pub rate_hz: f64,
    /// `[actors.camera.params.camera]`: the rig.
    pub camera: StereoCameraParams,
}

impl Default for CameraSimParams {
    fn default() -> CameraSimParams {
        CameraSimParams {
            world: PathBuf::from("worlds/empty.toml"),
            rate_hz: 15.0,
            camera: StereoCameraParams::default(),
        }
    }
}

/// Ground truth → rendered stereo frames; ports `ground_truth` (input) and `stereo_frame`
/// (output).
pub struct CameraSimActor {
    camera: StereoCamera,
    scene: Scene,
    rate_hz: f64,
    /// Time of the first sample: frame `k` is due `k/rate_hz` after it; `None` before it.
    origin: Option<Time>,
    /// Index of the next frame due.
    next_slot: u64,
    sequence: u64,
    /// True depth of the last published frame's left image.
    last_depth: Option<DepthImage>,
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

    /// When frame slot `slot` is due, counting from `origin` (rounded to the µs, without
    /// accumulating rounding error).
    fn due(&self, origin: Time, slot: u64) -> Time {
        Time(origin.0 + (slot as f64 * 1e6 / self.rate_hz).round() as u64)
    }
}

impl Actor for CameraSimActor {
    type Params = CameraSimParams;
    type Input = GroundTruth;

    fn build(
        params: &CameraSimParams,
        setup: &mut impl Setup<GroundTruth>,
    ) -> Result<CameraSimActor, ActorError> {
        if !(params.rate_hz.is_finite() && params.rate_hz > 0.0 && params.rate_hz <= 1000.0) {
            return Err(ActorError::Params(format!("rate_hz must be in (0, 1000], got {}", params.rate_hz)));
        }
        let camera =
            StereoCamera::new(&params.camera).map_err(|e| ActorError::Params(format!("camera: {e}")))?;
        let world = World::load(&setup.config_dir().join(&params.world))
            .map_err(|e| ActorError::Params(e.to_string()))?;
        setup.input("ground_truth", |truth| truth);
        Ok(CameraSimActor {
            camera,
            scene: Scene::new(&world.obstacles),
            rate_hz: params.rate_hz,
            origin: None,
            next_slot: 0,
            sequence: 0,
            last_depth: None,
            out: setup.output("stereo_frame"),
        })
    }

    async fn handle(&mut self, _ctx: &Context, truth: GroundTruth) -> Result<(), ActorError> {
        let origin = *self.origin.get_or_insert(truth.time);
        if truth.time < self.due(origin, self.next_slot) {
            return Ok(());
        }
        let [w, x, y, z] = truth.attitude;
        let attitude = UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z));
        let position = Vector3::from(truth.position_ned_m);
        let render = self.camera.render(&self.scene, &position, &attitude, self.sequence);
        let (frame, depth) =
            render.into_frame(truth.time, self.sequence).map_err(|e| ActorError::Failed(e.to_string()))?;
        self.out.publish(frame);
        self.last_depth = Some(depth);
        self.sequence += 1;
        while self.due(origin, self.next_slot) <= truth.time {
            self.next_slot += 1;
        }
        Ok(())
    }
}
