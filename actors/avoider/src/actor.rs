//! The avoider as an actor: depth grids and setpoints in, `AvoidanceCommand` out.
//!
//! Ports (type `avoider` once registered):
//! * input `depth_grid` (`DepthGrid`): each accepted grid publishes one command;
//! * input `setpoint` (`Setpoint`): the commander's demand, for the desired speed;
//! * timer `check` (every `check_period_s`): publishes the stale command while no fresh grid
//!   arrives;
//! * output `avoidance_command` (`AvoidanceCommand`).
//!
//! Refused inputs are counted in the command's health and logged at the 1st, 2nd, 4th, 8th…
//! refusal, so a broken camera cannot flood the log.

use std::time::Duration;

use kestrel_proto::messages::{AvoidanceCommand, DepthGrid, Setpoint};
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup, Time};

use crate::avoidance::Avoider;
use crate::avoidance::params::AvoiderParams;
use crate::{rule_file, thesis_engine};

/// What the avoider actor handles.
#[derive(Debug)]
pub enum AvoiderInput {
    /// A depth grid from the stereo engine (port `depth_grid`).
    DepthGrid(DepthGrid),
    /// The commander's setpoint (port `setpoint`).
    Setpoint(Setpoint),
    /// The staleness check (timer `check`), at its scheduled time.
    Check(Time),
}

/// The obstacle avoider actor (thesis §3.3).
pub struct AvoiderActor {
    avoider: Avoider,
    command: Publisher<AvoidanceCommand>,
}

impl AvoiderActor {
    /// The core, for inspection.
    pub fn avoider(&self) -> &Avoider {
        &self.avoider
    }
}

impl Actor for AvoiderActor {
    type Params = AvoiderParams;
    type Input = AvoiderInput;

    fn build(
        params: &AvoiderParams,
        setup: &mut impl Setup<AvoiderInput>,
    ) -> Result<AvoiderActor, ActorError> {
        let engine = match &params.rules {
            Some(path) => rule_file::load(&setup.config_dir().join(path)),
            None => thesis_engine(),
        }
        .map_err(|e| ActorError::Params(e.to_string()))?;
        let avoider = Avoider::new(engine, params.clone()).map_err(|e| ActorError::Params(e.to_string()))?;
        let period = Duration::try_from_secs_f64(params.check_period_s)
            .map_err(|e| ActorError::Params(format!("check_period_s = {}: {e}", params.check_period_s)))?;
        setup.input("depth_grid", AvoiderInput::DepthGrid);
        setup.input("setpoint", AvoiderInput::Setpoint);
        setup.timer("check", period, AvoiderInput::Check);
        Ok(AvoiderActor { avoider, command: setup.output("avoidance_command") })
    }

    async fn handle(&mut self, ctx: &Context, input: AvoiderInput) -> Result<(), ActorError> {
        match input {
            AvoiderInput::DepthGrid(grid) => match self.avoider.update(ctx.now(), &grid) {
                Ok(command) => self.command.publish(command),
                Err(e) if self.avoider.grids_rejected().is_power_of_two() => {
                    tracing::warn!(actor = ctx.name(), rejected = self.avoider.grids_rejected(), "{e}");
                }
                Err(_) => {}
            },
            AvoiderInput::Setpoint(setpoint) => match self.avoider.set_setpoint(&setpoint) {
                Err(e) if self.avoider.setpoints_rejected().is_power_of_two() => {
                    tracing::warn!(actor = ctx.name(), rejected = self.avoider.setpoints_rejected(), "{e}");
                }
                Ok(()) | Err(_) => {}
            },
            AvoiderInput::Check(time) => {
                if let Some(command) = self.avoider.check(time) {
                    self.command.publish(command);
                }
            }
        }
        Ok(())
    }
}
