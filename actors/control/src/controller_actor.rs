//! `ControllerActor`: the actor shell of the control loop.
//!
//! Ports — inputs `nav` (NavState, mailbox `latest`), `setpoint` (Setpoint, `latest`),
//! `param_set` (ParamSet, `queue`), and for the backup attitude (`crate::backup_attitude`) the raw
//! `imu` (ImuSample, `queue`: every sample is integrated), `mag` (MagSample) and `baro`
//! (BaroSample); timer `tick` at the loop rate (lockstep only); outputs `actuators`
//! (ActuatorOutputs), `loop_stats` (ControlLoopStats, about 1 Hz), `backup_nav` (NavState: the
//! backup's state, each iteration that flew on it, for the commander and the flight report) and
//! `param_decl` (ParamDecl: the live gains of [`crate::live_params`], at start and after each
//! `param_set` naming one of them). Without `imu` routed the backup never aligns and a lost
//! NavState is flown blind, as before it existed.
//!
//! Two ways to run, chosen by `loop_mode`:
//! * `lockstep` (simulation): one loop iteration per NavState received, in the actor's handler,
//!   like PX4's SITL lockstep: the simulator's next step waits for these outputs, so control
//!   runs in step with simulated time and never sleeps on the clock. The `tick` timer (graph
//!   clock, so still deterministic) covers NavStates that stop: a tick with no NavState handled
//!   since the previous one, and none fresh within `timing.nav_timeout_s`, runs the same
//!   fallback as the thread — fly on the backup attitude, else blind, or idle when the setpoint
//!   is disarmed — so the motors never keep the last command forever. While NavStates arrive
//!   the ticks do nothing.
//! * `thread` (hardware, `clock = "realtime"`): the loop runs on its own OS thread with
//!   SCHED_FIFO where permitted (logged either way), one iteration per NavState with a watchdog
//!   at 1.5 periods (`rt/thread.rs`); the handler only drops each input into a lock-free triple
//!   buffer (and wakes the thread for a NavState) and returns. The thread hands its motor
//!   commands back the same way and its timing through a sample ring (publishing locks the
//!   topic's mailboxes and the recorder allocates, which the loop must not); a tokio task
//!   started with the actor publishes the newest commands at the loop rate, keeps the loop's
//!   statistics from the samples and publishes them about once a second, until
//!   `ctx.shutdown()` or the thread ends: outputs reach subscribers at most about one loop
//!   period after they were computed. New gains go the other way through a third triple
//!   buffer, validated here first: the thread copies them in before its next iteration.

use std::time::Duration;

use kestrel_proto::messages::{
    ActuatorOutputs, BaroSample, ControlLoopStats, ImuSample, MagSample, NavState, ParamDecl, ParamSet,
    Setpoint,
};
use kestrel_proto::param_def::{self, ParamChange};
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup, Time};
use serde::Deserialize;

use crate::backup_attitude::ImuReading;
use crate::flight_controller::{FlightController, LoopCounters};
use crate::live_params::{Gains, Tuning};
use crate::params::ControlParams;
use crate::rt::{
    ControlThread, Granted, LoopSample, LoopStats, Reader, RealtimeSettings, RingReader, RingWriter,
    ThreadInputs, ThreadOutput, Writer, sample_ring, triple_buffer,
};

/// Timing samples the relay can fall behind by before the loop's are dropped (and counted):
/// about 2.5 s at 400 Hz.
const SAMPLE_RING: usize = 1024;
/// IMU samples the loop thread can fall behind by before the backup attitude misses some
/// (counted by the ring): 160 ms at 400 Hz.
const IMU_RING: usize = 64;

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
    /// Lock the process's memory into RAM for the loop thread (`mlockall`, as ArduPilot's Linux
    /// scheduler does); refused without the privilege, and said so.
    pub lock_memory: bool,
    /// Pin the loop thread to this CPU (0-based; ArduPilot's `--cpu-affinity`); none: unpinned.
    pub cpu: Option<usize>,
    /// Gains, limits and airframe; defaults fly `config/vehicles/quad_x.toml`. The airframe
    /// comes from the graph's vehicle file where the graph names one (`src/vehicle.rs`).
    pub control: ControlParams,
}

impl Default for ControllerActorParams {
    fn default() -> ControllerActorParams {
        ControllerActorParams {
            loop_mode: LoopMode::Lockstep,
            priority: 80,
            lock_memory: true,
            cpu: None,
            control: ControlParams::default(),
        }
    }
}

/// What the controller actor handles.
#[derive(Debug)]
pub enum ControllerInput {
    Nav(NavState),
    Setpoint(Setpoint),
    /// A parameter change from the link (applied when it names one of our gains).
    Param(ParamSet),
    /// The lockstep loop's timer, at the loop rate.
    Tick(Time),
    /// Raw sensor samples for the backup attitude.
    Imu(ImuSample),
    Mag(MagSample),
    Baro(BaroSample),
}

struct Outputs {
    actuators: Publisher<ActuatorOutputs>,
    stats: Publisher<ControlLoopStats>,
    backup_nav: Publisher<NavState>,
}

/// The loop thread's side of its outputs: triple buffers and a ring, so it never locks or
/// allocates.
struct BufferedOutputs {
    granted: Writer<Option<Granted>>,
    actuators: Writer<Option<ActuatorOutputs>>,
    backup_nav: Writer<Option<NavState>>,
    samples: RingWriter<LoopSample>,
    counters: Writer<LoopCounters>,
}

impl ThreadOutput for BufferedOutputs {
    fn granted(&mut self, granted: Granted) {
        self.granted.write(Some(granted));
    }

    fn actuators(&mut self, outputs: &ActuatorOutputs) {
        self.actuators.write(Some(outputs.clone()));
    }

    fn backup_nav(&mut self, nav: &NavState) {
        self.backup_nav.write(Some(nav.clone()));
    }

    fn record(&mut self, sample: LoopSample, counters: LoopCounters) {
        // A full ring is counted by the ring itself and reported as `dropped_samples`.
        let _ = self.samples.push(sample);
        self.counters.write(counters);
    }
}

/// The publishing side: a tokio task reads the buffers every period, publishes the newest
/// commands, and keeps and publishes the loop's statistics.
struct Relay {
    granted: Reader<Option<Granted>>,
    actuators: Reader<Option<ActuatorOutputs>>,
    backup_nav: Reader<Option<NavState>>,
    samples: RingReader<LoopSample>,
    counters: Reader<LoopCounters>,
    stats: LoopStats,
    outputs: Outputs,
    period: Duration,
    /// Relay periods between statistics messages (about a second).
    stats_every: u64,
}

impl Relay {
    /// Publishes until `shutdown` or the thread is gone.
    async fn run(
        mut self,
        clock: std::sync::Arc<dyn kestrel_proto::Clock>,
        shutdown: impl Future<Output = ()>,
    ) {
        let mut shutdown = std::pin::pin!(shutdown);
        let mut interval = tokio::time::interval(self.period);
        interval.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        let mut ticks = 0u64;
        loop {
            tokio::select! {
                () = &mut shutdown => break,
                _ = interval.tick() => {}
            }
            // Checked before reading, so what the thread wrote before it ended is still sent.
            let gone = self.actuators.writer_gone();
            if let (Some(out), true) = self.actuators.read() {
                self.outputs.actuators.publish(out.clone());
            }
            if let (Some(nav), true) = self.backup_nav.read() {
                self.outputs.backup_nav.publish(nav.clone());
            }
            let stats = &mut self.stats;
            self.samples.drain(|sample| stats.record(sample));
            ticks += 1;
            if ticks.is_multiple_of(self.stats_every) || gone {
                let granted = self.granted.read().0.unwrap_or_default();
                let counters = *self.counters.read().0;
                let message =
                    self.stats.message(clock.now(), counters, Some(granted), self.samples.dropped());
                self.outputs.stats.publish(message);
            }
            if gone {
                break;
            }
        }
    }
}

/// Everything the loop thread and its relay own, built with the actor and handed over at start.
struct Pending {
    ctl: Box<FlightController>,
    nav: Reader<Option<NavState>>,
    setpoint: Reader<Option<Setpoint>>,
    gains: Reader<Option<Gains>>,
    imu: RingReader<ImuReading>,
    mag: Reader<Option<MagSample>>,
    baro: Reader<Option<BaroSample>>,
    outputs: BufferedOutputs,
    relay: Relay,
}

enum Loop {
    Lockstep {
        ctl: Box<FlightController>,
        stats: LoopStats,
        outputs: Outputs,
        iterations: u64,
        /// Time of the newest NavState handled.
        last_nav: Option<Time>,
        /// A NavState was handled since the previous tick.
        nav_since_tick: bool,
    },
    Thread {
        nav: Writer<Option<NavState>>,
        setpoint: Writer<Option<Setpoint>>,
        gains: Writer<Option<Gains>>,
        imu: RingWriter<ImuReading>,
        mag: Writer<Option<MagSample>>,
        baro: Writer<Option<BaroSample>>,
        /// What the thread takes when it starts.
        pending: Option<Box<Pending>>,
        thread: Option<ControlThread>,
        relay: Option<tokio::task::JoinHandle<()>>,
        os: RealtimeSettings,
    },
}

/// The control loop actor.
pub struct ControllerActor {
    inner: Loop,
    /// The live gains, changed here and handed to the loop.
    tuning: Tuning,
    param_decl: Publisher<ParamDecl>,
    /// Our name in the config: the owner named in `param_decl`.
    name: String,
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
        setup.input("param_set", ControllerInput::Param);
        setup.input("imu", ControllerInput::Imu);
        setup.input("mag", ControllerInput::Mag);
        setup.input("baro", ControllerInput::Baro);
        let param_decl = setup.output("param_decl");
        let outputs = Outputs {
            actuators: setup.output("actuators"),
            stats: setup.output("loop_stats"),
            backup_nav: setup.output("backup_nav"),
        };
        let period_us = (1e6 / params.control.timing.rate_hz).round() as u64;
        let inner = match params.loop_mode {
            LoopMode::Lockstep => {
                setup.timer("tick", Duration::from_micros(period_us), ControllerInput::Tick);
                Loop::Lockstep {
                    ctl: Box::new(ctl),
                    stats: LoopStats::lockstep(period_us),
                    outputs,
                    iterations: 0,
                    last_nav: None,
                    nav_since_tick: false,
                }
            }
            LoopMode::Thread => {
                let (nav, nav_reader) = triple_buffer(None);
                let (setpoint, setpoint_reader) = triple_buffer(None);
                let (gains, gains_reader) = triple_buffer(None);
                let (granted, granted_reader) = triple_buffer(None);
                let (actuators, actuators_reader) = triple_buffer(None);
                let (backup_nav, backup_nav_reader) = triple_buffer(None);
                let (imu, imu_reader) = sample_ring(IMU_RING, ImuReading::default());
                let (mag, mag_reader) = triple_buffer(None);
                let (baro, baro_reader) = triple_buffer(None);
                let (samples, samples_reader) = sample_ring(SAMPLE_RING, LoopSample::default());
                let (counters, counters_reader) = triple_buffer(LoopCounters::default());
                Loop::Thread {
                    nav,
                    setpoint,
                    gains,
                    imu,
                    mag,
                    baro,
                    pending: Some(Box::new(Pending {
                        ctl: Box::new(ctl),
                        nav: nav_reader,
                        setpoint: setpoint_reader,
                        gains: gains_reader,
                        imu: imu_reader,
                        mag: mag_reader,
                        baro: baro_reader,
                        outputs: BufferedOutputs { granted, actuators, backup_nav, samples, counters },
                        relay: Relay {
                            granted: granted_reader,
                            actuators: actuators_reader,
                            backup_nav: backup_nav_reader,
                            samples: samples_reader,
                            counters: counters_reader,
                            stats: LoopStats::new(period_us),
                            outputs,
                            period: Duration::from_micros(period_us),
                            stats_every: params.control.timing.rate_hz.round().max(1.0) as u64,
                        },
                    })),
                    thread: None,
                    relay: None,
                    os: RealtimeSettings {
                        priority: params.priority,
                        lock_memory: params.lock_memory,
                        cpu: params.cpu,
                    },
                }
            }
        };
        Ok(ControllerActor {
            inner,
            tuning: Tuning::new(params.control.clone()),
            param_decl,
            name: setup.name().to_owned(),
        })
    }

    async fn start(&mut self, ctx: &Context) -> Result<(), ActorError> {
        self.param_decl.publish(self.tuning.decl(&self.name, true, ctx.now()));
        if let Loop::Thread { pending, thread, relay, os, .. } = &mut self.inner
            && let Some(pending) = pending.take()
        {
            let Pending { ctl, nav, setpoint, gains, imu, mag, baro, outputs, relay: publisher } = *pending;
            let inputs = ThreadInputs { nav, setpoint, gains, imu, mag, baro };
            let spawned =
                ControlThread::spawn(*ctl, inputs, ctx.clock().clone(), outputs, *os).map_err(|source| {
                    ActorError::Io { what: "cannot start the control thread".into(), source }
                })?;
            *thread = Some(spawned);
            let clock = ctx.clock().clone();
            *relay = Some(tokio::spawn(publisher.run(clock, ctx.shutdown().clone().cancelled_owned())));
        }
        Ok(())
    }

    async fn handle(&mut self, ctx: &Context, input: ControllerInput) -> Result<(), ActorError> {
        if let ControllerInput::Param(p) = input {
            self.on_param(ctx, &p);
            return Ok(());
        }
        match (&mut self.inner, input) {
            (
                Loop::Lockstep { ctl, stats, outputs, iterations, last_nav, nav_since_tick },
                ControllerInput::Nav(nav),
            ) => {
                *last_nav = Some(nav.time);
                *nav_since_tick = true;
                let started = std::time::Instant::now();
                let out = ctl.update(&nav);
                lockstep_output(ctx, ctl, stats, outputs, iterations, nav.time, out, started, true);
            }
            (
                Loop::Lockstep { ctl, stats, outputs, iterations, last_nav, nav_since_tick },
                ControllerInput::Tick(now),
            ) => {
                // The NavState handler runs the loop while NavStates arrive; the tick only acts
                // when they have stopped (the thread's rule: no fresh NavState → fly on the
                // backup attitude, else blind, which idles when the setpoint is disarmed).
                let handled = std::mem::take(nav_since_tick);
                let timeout_s = ctl.params().timing.nav_timeout_s;
                let fresh = last_nav.is_some_and(|t| now.saturating_since(t).as_secs_f64() <= timeout_s);
                if !handled && !fresh {
                    let started = std::time::Instant::now();
                    let out = ctl.fly_without_nav(now);
                    lockstep_output(ctx, ctl, stats, outputs, iterations, now, out, started, false);
                }
            }
            (Loop::Lockstep { ctl, .. }, ControllerInput::Imu(imu)) => ctl.on_imu(&ImuReading::from(&imu)),
            (Loop::Lockstep { ctl, .. }, ControllerInput::Mag(mag)) => ctl.on_mag(&mag),
            (Loop::Lockstep { ctl, .. }, ControllerInput::Baro(baro)) => ctl.on_baro(&baro),
            // A full ring drops the sample (counted by the ring): the loop never waits.
            (Loop::Thread { imu: ring, .. }, ControllerInput::Imu(imu)) => {
                let _ = ring.push(ImuReading::from(&imu));
            }
            (Loop::Thread { mag: to_thread, .. }, ControllerInput::Mag(mag)) => to_thread.write(Some(mag)),
            (Loop::Thread { baro: to_thread, .. }, ControllerInput::Baro(baro)) => {
                to_thread.write(Some(baro))
            }
            (Loop::Lockstep { ctl, .. }, ControllerInput::Setpoint(sp)) => {
                if let Err(e) = ctl.set_setpoint(&sp) {
                    tracing::warn!(error = %e, rejected = ctl.counters().rejected_setpoints, "setpoint refused");
                }
            }
            (Loop::Thread { nav, thread, .. }, ControllerInput::Nav(n)) => {
                nav.write(Some(n));
                if let Some(t) = thread {
                    t.wake();
                }
            }
            (Loop::Thread { setpoint, .. }, ControllerInput::Setpoint(sp)) => setpoint.write(Some(sp)),
            // The thread keeps its own schedule; no timer is declared in this mode.
            (Loop::Thread { .. }, ControllerInput::Tick(_)) => {}
            // Handled above.
            (_, ControllerInput::Param(_)) => {}
        }
        Ok(())
    }

    async fn stop(&mut self, _ctx: &Context) {
        if let Loop::Thread { thread, relay, .. } = &mut self.inner {
            if let Some(t) = thread {
                t.stop();
            }
            // With the thread gone the relay sends what is left and ends within a period.
            if let Some(r) = relay.take()
                && let Err(e) = r.await
            {
                tracing::error!(error = %e, "control output relay failed");
            }
        }
    }
}

impl ControllerActor {
    /// Applies a `ParamSet` naming one of our gains: checked and validated here, then handed to
    /// the loop (directly in lockstep, through the triple buffer to the thread). Applied or
    /// refused, the link is told the values in use.
    fn on_param(&mut self, ctx: &Context, p: &ParamSet) {
        let outcome = self.tuning.apply(&p.name, p.value);
        if outcome == Ok(ParamChange::Applied) {
            let gains = self.tuning.gains();
            match &mut self.inner {
                Loop::Lockstep { ctl, .. } => ctl.retune(&gains),
                Loop::Thread { gains: to_thread, .. } => to_thread.write(Some(gains)),
            }
        }
        if param_def::answer(ctx.name(), p, outcome) {
            self.param_decl.publish(self.tuning.decl(&self.name, false, ctx.now()));
        }
    }
}

/// Publishes one lockstep iteration's outputs and records its timing (statistics about 1 Hz);
/// `nav_driven`: a NavState ran it (its age is 0 on the graph clock), not the tick.
#[allow(clippy::too_many_arguments)]
fn lockstep_output(
    ctx: &Context,
    ctl: &FlightController,
    stats: &mut LoopStats,
    outputs: &Outputs,
    iterations: &mut u64,
    at: Time,
    out: ActuatorOutputs,
    started: std::time::Instant,
    nav_driven: bool,
) {
    let execution_us = kestrel_proto::time::duration_micros(started.elapsed());
    outputs.actuators.publish(out);
    if let Some(nav) = ctl.flown_backup() {
        outputs.backup_nav.publish(nav.clone());
    }
    stats.record(LoopSample { start_us: at.as_micros(), execution_us, nav_age_us: nav_driven.then_some(0) });
    *iterations += 1;
    let every = ctl.params().timing.rate_hz.round().max(1.0) as u64;
    if iterations.is_multiple_of(every) {
        outputs.stats.publish(stats.message(ctx.now(), ctl.counters(), None, 0));
    }
}
