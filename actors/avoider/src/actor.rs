//! The avoider as an actor: depth grids and setpoints in, `AvoidanceCommand` out.
//!
//! Ports (type `avoider` once registered):
//! * input `depth_grid` (`DepthGrid`): each accepted grid publishes one command;
//! * input `setpoint` (`Setpoint`): the commander's demand, for the desired speed;
//! * input `nav` (`NavState`, optional): the estimator's pose, which places what the camera
//!   saw in the short-term obstacle memory; unrouted, the avoider has no memory;
//! * input `vehicle_status` (`VehicleStatus`, optional): home, for the height above the ground
//!   (`ground_match_height_m`); unrouted, the height is above the estimator's origin;
//! * input `rangefinder_down` (`RangefinderSample`, optional): the downward rangefinder, the
//!   better measure of that height while it returns a distance;
//! * timer `check` (every `check_period_s`): publishes the stale command while no fresh grid
//!   arrives;
//! * input `param_set` (`ParamSet`): changes to the live settings of
//!   [`crate::avoidance::live_params`];
//! * output `avoidance_command` (`AvoidanceCommand`);
//! * output `param_decl` (`ParamDecl`): those settings, at start and after each `param_set`
//!   naming one of them.
//!
//! Refused inputs are counted in the command's health and logged at the 1st, 2nd, 4th, 8th…
//! refusal, so a broken camera cannot flood the log.

use kestrel_proto::messages::{
    AvoidanceCommand, DepthGrid, NavState, ParamDecl, ParamSet, RangefinderSample, Setpoint, VehicleStatus,
};
use kestrel_proto::param_def::{self, ParamChange};
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup, Time};

use crate::avoidance::params::AvoiderParams;
use crate::avoidance::{Avoider, live_params};
use crate::{rule_file, thesis_engine};

/// What the avoider actor handles.
#[derive(Debug)]
pub enum AvoiderInput {
    /// A depth grid from the stereo engine (port `depth_grid`).
    DepthGrid(DepthGrid),
    /// The commander's setpoint (port `setpoint`).
    Setpoint(Setpoint),
    /// The estimator's state (port `nav`).
    Nav(Box<NavState>),
    /// Home's NED position from the commander's status (port `vehicle_status`).
    Home(Option<[f64; 3]>),
    /// The downward rangefinder (port `rangefinder_down`).
    Range(RangefinderSample),
    /// The staleness check (timer `check`), at its scheduled time.
    Check(Time),
    /// A parameter change from the link (port `param_set`).
    Param(ParamSet),
}

/// The obstacle avoider actor (thesis §3.3).
pub struct AvoiderActor {
    avoider: Avoider,
    command: Publisher<AvoidanceCommand>,
    param_decl: Publisher<ParamDecl>,
    /// Our name in the config: the owner named in `param_decl`.
    name: String,
}

impl AvoiderActor {
    /// The core, for inspection.
    pub fn avoider(&self) -> &Avoider {
        &self.avoider
    }

    /// Applies a `ParamSet` naming one of our settings; applied or refused, the link is told
    /// the values in use.
    fn on_param(&mut self, ctx: &Context, p: &ParamSet) {
        let mut params = self.avoider.params().clone();
        let outcome = match live_params::apply(&mut params, &p.name, p.value) {
            Ok(ParamChange::Applied) => {
                self.avoider.retune(params).map(|()| ParamChange::Applied).map_err(|e| e.to_string())
            }
            other => other.map_err(|e| e.to_string()),
        };
        if param_def::answer(ctx.name(), p, outcome) {
            self.param_decl.publish(live_params::decl(self.avoider.params(), &self.name, false, ctx.now()));
        }
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
        let period = kestrel_proto::timing::seconds("check_period_s", params.check_period_s, 1e-3, 10.0)?;
        setup.input("depth_grid", AvoiderInput::DepthGrid);
        setup.input("setpoint", AvoiderInput::Setpoint);
        setup.input("nav", |nav| AvoiderInput::Nav(Box::new(nav)));
        setup.input("vehicle_status", |status: VehicleStatus| {
            AvoiderInput::Home(status.home.map(|home| home.position_ned_m))
        });
        setup.input("rangefinder_down", AvoiderInput::Range);
        setup.input("param_set", AvoiderInput::Param);
        setup.timer("check", period, AvoiderInput::Check);
        Ok(AvoiderActor {
            avoider,
            command: setup.output("avoidance_command"),
            param_decl: setup.output("param_decl"),
            name: setup.name().to_owned(),
        })
    }

    async fn start(&mut self, ctx: &Context) -> Result<(), ActorError> {
        self.param_decl.publish(live_params::decl(self.avoider.params(), &self.name, true, ctx.now()));
        Ok(())
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
            AvoiderInput::Nav(nav) => self.avoider.set_pose(&nav),
            AvoiderInput::Home(home) => self.avoider.set_home(home),
            AvoiderInput::Range(sample) => self.avoider.set_range(&sample),
            AvoiderInput::Check(time) => {
                if let Some(command) = self.avoider.check(time) {
                    self.command.publish(command);
                }
            }
            AvoiderInput::Param(p) => self.on_param(ctx, &p),
        }
        Ok(())
    }
}
