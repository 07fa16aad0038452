//! The full-surround sectors as an actor (type `proximity` once registered).
//!
//! Ports:
//! * input `depth_grid` (`DepthGrid`): each accepted grid publishes one `Proximity`;
//! * input `nav` (`NavState`): the pose that places what the camera saw in the obstacle
//!   memory (the estimator's, or in a companion graph the flight controller's); unrouted, the
//!   sectors are the camera's alone;
//! * output `proximity` (`Proximity`).
//!
//! Refused grids are logged at the 1st, 2nd, 4th, 8th… refusal, so a broken camera cannot
//! flood the log. Nothing is published without a fresh grid: a stopped camera stops the
//! sectors, and the flight controller times them out (ArduPilot after 0.5 s).

use kestrel_proto::messages::{DepthGrid, NavState, Proximity};
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup};

use crate::proximity::SurroundSectors;
use crate::proximity::params::ProximityParams;

/// What the proximity actor handles.
#[derive(Debug)]
pub enum ProximityInput {
    /// A depth grid from the stereo engine (port `depth_grid`).
    DepthGrid(Box<DepthGrid>),
    /// The vehicle's state (port `nav`).
    Nav(Box<NavState>),
}

/// The full-surround sectors actor.
pub struct ProximityActor {
    core: SurroundSectors,
    proximity: Publisher<Proximity>,
}

impl ProximityActor {
    /// The core, for inspection.
    pub fn core(&self) -> &SurroundSectors {
        &self.core
    }
}

impl Actor for ProximityActor {
    type Params = ProximityParams;
    type Input = ProximityInput;

    fn build(
        params: &ProximityParams,
        setup: &mut impl Setup<ProximityInput>,
    ) -> Result<ProximityActor, ActorError> {
        let core = SurroundSectors::new(params).map_err(|e| ActorError::Params(e.to_string()))?;
        setup.input("depth_grid", |grid| ProximityInput::DepthGrid(Box::new(grid)));
        setup.input("nav", |nav| ProximityInput::Nav(Box::new(nav)));
        Ok(ProximityActor { core, proximity: setup.output("proximity") })
    }

    async fn handle(&mut self, ctx: &Context, input: ProximityInput) -> Result<(), ActorError> {
        match input {
            ProximityInput::DepthGrid(grid) => match self.core.update(ctx.now(), &grid) {
                Ok(sectors) => self.proximity.publish(sectors),
                Err(e) if self.core.rejected().is_power_of_two() => {
                    tracing::warn!(actor = ctx.name(), rejected = self.core.rejected(), "{e}");
                }
                Err(_) => {}
            },
            ProximityInput::Nav(nav) => self.core.set_pose(&nav),
        }
        Ok(())
    }
}
