//! `ControllerActor`: the actor shell of the control loop.
//!
//! Ports — inputs `nav` (NavState, mailbox `latest`) and `setpoint` (Setpoint, `latest`);
//! outputs `actuators` (ActuatorOutputs) and `loop_stats` (ControlLoopStats, about 1 Hz).
//!
//! Two ways to run, chosen by `loop_mode`:
//! * `lockstep` (simulation): one loop iteration per NavState received, in the actor's handler,
//!   like PX4's SITL lockstep: the simulator's next step waits for these outputs, so control
//!   runs in step with simulated time and never sleeps on the clock.
//! * `thread` (hardware, `clock = "realtime"`): the loop runs on its own OS thread at
//!   `control.timing.rate_hz` with SCHED_FIFO where permitted (logged either way); the handler
//!   only drops each input into a lock-free triple buffer and returns.

use kestrel_proto::messages::{ActuatorOutputs, ControlLoopStats, NavState, Setpoint};
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup};
use serde::Deserialize;

use crate::flight_controller::FlightController;
use crate::params::ControlParams;
use crate::rt::{ControlThread, LoopStats, Reader, ThreadOutput, Writer, triple_buffer};

/// How the loop is clocked.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LoopMode {
    /// One iteration per NavState, in the handler (simulation under the lockstep clock).
    #[default]
    Lockstep,
    /// A dedicated OS thread at the loop rate (hardware, realtime clock).
    Thread,
}

/// `[actors.controller.params]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ControllerActorParams {
    pub loop_mode: LoopMode,
    /// SCHED_FIFO priority of the loop thread, 1..=99 (PX4 runs its rate loop near the top).
    pub priority: i32,
    /// Gains, limits and airframe; defaults fly `config/vehicles/quad_x.toml`.
    pub control: ControlParams,
}

impl Default for ControllerActorParams {
    fn default() -> ControllerActorParams {
        ControllerActorParams {
            loop_mode: LoopMode::Lockstep,
            priority: 80,
            control: ControlParams::default(),
        }
    }
}

/// What the controller actor handles.
#[derive(Debug)]
pub enum ControllerInput {
    Nav(NavState),
    Setpoint(Setpoint),
}

struct Outputs {
    actuators: Publisher<ActuatorOutputs>,
    stats: Publisher<ControlLoopStats>,
}

impl ThreadOutput for Outputs {
    fn actuators(&mut self, outputs: &ActuatorOutputs) {
        self.actuators.publish(outputs.clone());
    }

    fn stats(&mut self, stats: ControlLoopStats) {
        self.stats.publish(stats);
    }
}

/// Everything the loop thread owns, built with the actor and handed over at start.
struct Pending {
    ctl: Box<FlightController>,
    nav: Reader<Option<NavState>>,
    setpoint: Reader<Option<Setpoint>>,
    outputs: Outputs,
}

enum Loop {
    Lockstep {
        ctl: Box<FlightController>,
        stats: LoopStats,
        outputs: Outputs,
        iterations: u64,
    },
    Thread {
        nav: Writer<Option<NavState>>,
        setpoint: Writer<Option<Setpoint>>,
        /// What the thread takes when it starts.
        pending: Option<Pending>,
        thread: Option<ControlThread>,
        priority: i32,
    },
}

/// The control loop actor.
pub struct ControllerActor {
    inner: Loop,
}

impl Actor for ControllerActor {
    type Params = ControllerActorParams;
    type Input = ControllerInput;

    fn build(
        params: &ControllerActorParams,
        setup: &mut impl Setup<ControllerInput>,
    ) -> Result<Self, ActorError> {
        let ctl =
            FlightController::new(params.control.clone()).map_err(|e| ActorError::Params(e.to_string()))?;
        setup.input("nav", ControllerInput::Nav);
        setup.input("setpoint", ControllerInput::Setpoint);
        let outputs = Outputs { actuators: setup.output("actuators"), stats: setup.output("loop_stats") };
        let period_us = (1e6 / params.control.timing.rate_hz).round() as u64;
        let inner = match params.loop_mode {
            LoopMode::Lockstep => Loop::Lockstep {
                ctl: Box::new(ctl),
                stats: LoopStats::new(period_us),
                outputs,
                iterations: 0,
            },
            LoopMode::Thread => {
                let (nav, nav_reader) = triple_buffer(None);
                let (setpoint, setpoint_reader) = triple_buffer(None);
                Loop::Thread {
                    nav,
                    setpoint,
                    pending: Some(Pending {
                        ctl: Box::new(ctl),
                        nav: nav_reader,
                        setpoint: setpoint_reader,
                        outputs,
                    }),
                    thread: None,
                    priority: params.priority,
                }
            }
        };
        Ok(ControllerActor { inner })
    }

    async fn start(&mut self, ctx: &Context) -> Result<(), ActorError> {
        if let Loop::Thread { pending, thread, priority, .. } = &mut self.inner
            && let Some(Pending { ctl, nav, setpoint, outputs }) = pending.take()
        {
            let spawned =
                ControlThread::spawn(*ctl, nav, setpoint, ctx.clock().clone(), outputs, *priority).map_err(
                    |source| ActorError::Io { what: "cannot start the control thread".into(), source },
                )?;
            *thread = Some(spawned);
        }
        Ok(())
    }

    async fn handle(&mut self, ctx: &Context, input: ControllerInput) -> Result<(), ActorError> {
        match (&mut self.inner, input) {
            (Loop::Lockstep { ctl, stats, outputs, iterations }, ControllerInput::Nav(nav)) => {
                let started = std::time::Instant::now();
                let out = ctl.update(&nav);
                let execution_us = u64::try_from(started.elapsed().as_micros()).unwrap_or(u64::MAX);
                outputs.actuators.publish(out);
                stats.record(nav.time.as_micros(), execution_us);
                *iterations += 1;
                let every = ctl.params().timing.rate_hz.round().max(1.0) as u64;
                if iterations.is_multiple_of(every) {
                    outputs.stats.publish(stats.message(ctx.now(), ctl.counters(), false, false));
                }
            }
            (Loop::Lockstep { ctl, .. }, ControllerInput::Setpoint(sp)) => {
                if let Err(e) = ctl.set_setpoint(&sp) {
                    tracing::warn!(error = %e, rejected = ctl.counters().rejected_setpoints, "setpoint refused");
                }
            }
            (Loop::Thread { nav, .. }, ControllerInput::Nav(n)) => nav.write(Some(n)),
            (Loop::Thread { setpoint, .. }, ControllerInput::Setpoint(sp)) => setpoint.write(Some(sp)),
        }
        Ok(())
    }

    async fn stop(&mut self, _ctx: &Context) {
        if let Loop::Thread { thread: Some(t), .. } = &mut self.inner {
            t.stop();
        }
    }
}
