//! The actor types a config can name in `type = "…"`.

use std::collections::BTreeMap;
use std::sync::Arc;

use kestrel_proto::Actor;

use crate::supervisor::{ActorKind, KindOf};

/// Actor types by config name.
#[derive(Clone, Default)]
pub struct Registry {
    kinds: BTreeMap<&'static str, Arc<dyn ActorKind>>,
}

impl Registry {
    /// An empty registry (tests add their own actors).
    pub fn new() -> Registry {
        Registry::default()
    }

    /// Every actor type Kestrel ships.
    pub fn standard() -> Registry {
        Registry::new()
            .with::<kestrel_sim::SimActor>("sim")
            .with::<kestrel_sim::CameraSimActor>("sim_camera")
            .with::<kestrel_estimator::EstimatorActor>("estimator")
            .with::<kestrel_avoider::AvoiderActor>("avoider")
            .with::<kestrel_vision::CameraActor>("camera")
            .with::<kestrel_vision::StereoActor>("stereo")
            .with::<kestrel_control::CommanderActor>("commander")
            .with::<kestrel_control::ControllerActor>("controller")
            .with::<kestrel_control::TruthNavActor>("truth_nav")
            .with::<kestrel_control::PilotScriptActor>("pilot_script")
            .with::<kestrel_link::LinkActor>("link")
            .with::<kestrel_sensors::BaroActor>("ms5611")
            .with::<kestrel_sensors::ImuActor>("mpu9250")
            .with::<kestrel_sensors::MotorActor>("pwm_motors")
            .with::<kestrel_sensors::GpsActor>("ublox_gps")
            .with::<kestrel_sensors::SbusActor>("sbus_rc")
            .with::<kestrel_sensors::RcioActor>("navio2_rcio")
            .with::<crate::log_replay::LogReplayActor>("log_replay")
    }

    /// Adds actor type `A` under `name`.
    pub fn with<A: Actor>(mut self, name: &'static str) -> Registry {
        self.kinds.insert(name, Arc::new(KindOf::<A>::default()));
        self
    }

    /// The actor type called `name`.
    pub fn get(&self, name: &str) -> Option<&Arc<dyn ActorKind>> {
        self.kinds.get(name)
    }

    /// All names, sorted.
    pub fn names(&self) -> Vec<&'static str> {
        self.kinds.keys().copied().collect()
    }
}
