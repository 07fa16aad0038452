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

    /// Every actor type Kestrel ships: [`Registry::flight`] and [`Registry::stand_ins`].
    pub fn standard() -> Registry {
        Registry::flight().stand_ins()
    }

    /// The actors a vehicle flies with, on hardware or in a simulated flight: estimation,
    /// perception, control, the link, the hardware drivers and, in a build with the `zenoh`
    /// feature, the bridge that joins graphs across machines.
    pub fn flight() -> Registry {
        let registry = Registry::drivers_and_cores();
        #[cfg(feature = "zenoh")]
        let registry = registry.with::<kestrel_bridge::BridgeActor>("bridge");
        registry
    }

    /// Estimation, perception, control, the link and the hardware drivers.
    fn drivers_and_cores() -> Registry {
        Registry::new()
            .with::<kestrel_estimator::EstimatorActor>("estimator")
            .with::<kestrel_avoider::AvoiderActor>("avoider")
            .with::<kestrel_avoider::ProximityActor>("proximity")
            .with::<kestrel_vision::CameraActor>("camera")
            .with::<kestrel_vision::StereoActor>("stereo")
            .with::<kestrel_control::CommanderActor>("commander")
            .with::<kestrel_control::ControllerActor>("controller")
            .with::<kestrel_link::LinkActor>("link")
            .with::<kestrel_link::CompanionActor>("companion_link")
            .with::<kestrel_sensors::CalibrationActor>("calibration")
            .with::<kestrel_sensors::BaroActor>("ms5611")
            .with::<kestrel_sensors::ImuActor>("mpu9250")
            .with::<kestrel_sensors::MotorActor>("pwm_motors")
            .with::<kestrel_sensors::GpsActor>("ublox_gps")
            .with::<kestrel_sensors::SbusActor>("sbus_rc")
            .with::<kestrel_sensors::RcioActor>("navio2_rcio")
    }

    /// Adds the actors that stand in for the world in simulations, benches and tests: the
    /// simulator and its camera, a recorded log (`log_replay`), and the test helpers
    /// `truth_nav` (ground truth as the navigation state), `pilot_script` (a pilot on a
    /// timetable) and `sim_gcs` (a ground station's heartbeats on the graph clock). None of them
    /// belongs in a vehicle's graph.
    pub fn stand_ins(self) -> Registry {
        self.with::<kestrel_sim::SimActor>("sim")
            .with::<kestrel_sim::hil::HilSimActor>("hil_sim")
            .with::<kestrel_sim::CameraSimActor>("sim_camera")
            .with::<crate::log_replay::LogReplayActor>("log_replay")
            .with::<kestrel_control::TruthNavActor>("truth_nav")
            .with::<kestrel_control::PilotScriptActor>("pilot_script")
            .with::<kestrel_link::SimGcsActor>("sim_gcs")
    }

    /// Adds actor type `A` under `name`.
    pub fn with<A: Actor>(mut self, name: &'static str) -> Registry {
        self.kinds.insert(name, Arc::new(KindOf::<A>::default()));
        self
    }

    /// Why an actor type Kestrel has is missing from this build, if it is one left out by a
    /// cargo feature.
    pub fn left_out(name: &str) -> Option<&'static str> {
        match name {
            #[cfg(not(feature = "zenoh"))]
            "bridge" => {
                Some("this kestrel was built without the Zenoh bridge (cargo build --features zenoh)")
            }
            _ => None,
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stand_ins_are_registered_apart_from_the_flight_actors() {
        let flight = Registry::flight().names();
        for stand_in in ["sim", "sim_camera", "log_replay", "truth_nav", "pilot_script", "sim_gcs"] {
            assert!(!flight.contains(&stand_in), "{stand_in} in {flight:?}");
            assert!(Registry::standard().get(stand_in).is_some(), "{stand_in}");
        }
        assert!(flight.iter().all(|name| Registry::standard().get(name).is_some()));
    }
}
