//! The control loop on its own OS thread (hardware, realtime clock): every period it takes the
//! newest gains, setpoint and NavState from triple buffers, runs one [`FlightController`] iteration
//! when a new NavState arrived (flies blind when the newest is older than the timeout), hands
//! the motor commands to `output`, and records its period and execution time. It never waits on
//! tokio or a lock, and allocates nothing per iteration; it ends when told to or when the
//! actor that feeds it is gone.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use kestrel_proto::Clock;
use kestrel_proto::messages::{ActuatorOutputs, ControlLoopStats, NavState, Setpoint};

use super::affinity::pin_to_cpu;
use super::loop_stats::LoopStats;
use super::memory::lock_memory;
use super::priority::{RealtimePriority, set_realtime_priority};
use super::triple_buffer::Reader;
use crate::flight_controller::FlightController;
use crate::live_params::Gains;

/// What the thread hands out: motor commands every iteration, statistics about once a second.
/// Called on the real-time thread, so an implementation must not lock or allocate: the actor
/// writes both into triple buffers and publishes them from a tokio task (at most about one
/// period later).
pub trait ThreadOutput: Send + 'static {
    fn actuators(&mut self, outputs: &ActuatorOutputs);
    fn stats(&mut self, stats: ControlLoopStats);
}

/// The triple buffers the thread reads each period.
pub struct ThreadInputs {
    pub nav: Reader<Option<NavState>>,
    pub setpoint: Reader<Option<Setpoint>>,
    /// New gains, already validated by the actor (see [`crate::live_params`]).
    pub gains: Reader<Option<Gains>>,
}

/// What the loop thread asks of the OS, each granted or refused with a log line and reported
/// in its [`ControlLoopStats`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RealtimeSettings {
    /// SCHED_FIFO priority (1..=99).
    pub priority: i32,
    /// Lock the process's memory into RAM (`mlockall`) before the loop's buffers are made.
    pub lock_memory: bool,
    /// Pin the loop thread to this CPU.
    pub cpu: Option<usize>,
}

/// A running control thread; stopped and joined on drop.
pub struct ControlThread {
    stop: Arc<AtomicBool>,
    realtime: Arc<AtomicBool>,
    handle: Option<JoinHandle<()>>,
}

impl ControlThread {
    /// Starts the loop at `ctl.params().timing.rate_hz` with what `os` asks for, where permitted.
    pub fn spawn(
        mut ctl: FlightController,
        inputs: ThreadInputs,
        clock: Arc<dyn Clock>,
        mut output: impl ThreadOutput,
        os: RealtimeSettings,
    ) -> std::io::Result<ControlThread> {
        let stop = Arc::new(AtomicBool::new(false));
        let realtime = Arc::new(AtomicBool::new(false));
        let (stop_flag, realtime_flag) = (Arc::clone(&stop), Arc::clone(&realtime));
        let ThreadInputs { mut nav, mut setpoint, mut gains } = inputs;
        let handle = std::thread::Builder::new().name("kestrel-control".into()).spawn(move || {
            let memory_locked = os.lock_memory
                && match lock_memory() {
                    Ok(()) => {
                        tracing::info!("control loop: memory locked (mlockall)");
                        true
                    }
                    Err(why) => {
                        tracing::warn!(%why, "control loop: memory not locked");
                        false
                    }
                };
            let pinned_cpu = os.cpu.and_then(|cpu| match pin_to_cpu(cpu) {
                Ok(()) => {
                    tracing::info!(cpu, "control loop pinned to its CPU");
                    u32::try_from(cpu).ok()
                }
                Err(why) => {
                    tracing::warn!(%why, "control loop not pinned");
                    None
                }
            });
            let got_fifo = match set_realtime_priority(os.priority) {
                RealtimePriority::Fifo(p) => {
                    tracing::info!(priority = p, "control loop on a SCHED_FIFO thread");
                    true
                }
                RealtimePriority::Normal(why) => {
                    tracing::warn!(%why, "control loop on a normal-priority thread");
                    false
                }
            };
            realtime_flag.store(got_fifo, Ordering::Release);
            let timing = ctl.params().timing.clone();
            let period = Duration::from_secs_f64(1.0 / timing.rate_hz);
            let period_us = u64::try_from(period.as_micros()).unwrap_or(u64::MAX);
            let stats_every = timing.rate_hz.round().max(1.0) as u64;
            let mut stats = LoopStats::new(period_us);
            let origin = Instant::now();
            let mut next = origin + period;
            let mut last = ActuatorOutputs::default();
            let mut iteration = 0u64;
            while !stop_flag.load(Ordering::Acquire) && !nav.writer_gone() {
                let now_wall = Instant::now();
                if next > now_wall {
                    std::thread::sleep(next - now_wall);
                }
                let started = Instant::now();
                let now = clock.now();
                if let (Some(g), true) = gains.read() {
                    ctl.retune(g);
                }
                if let (Some(sp), true) = setpoint.read() {
                    // A refused setpoint is counted by the controller and the last good one kept.
                    let _ = ctl.set_setpoint(sp);
                }
                last =
                    match nav.read() {
                        (Some(n), fresh)
                            if now.saturating_since(n.time).as_secs_f64() <= timing.nav_timeout_s =>
                        {
                            if fresh { ctl.update(n) } else { ActuatorOutputs { time: now, ..last } }
                        }
                        _ => ctl.fly_blind(now),
                    };
                output.actuators(&last);
                let execution = started.elapsed();
                stats.record(
                    u64::try_from((started - origin).as_micros()).unwrap_or(u64::MAX),
                    u64::try_from(execution.as_micros()).unwrap_or(u64::MAX),
                );
                iteration += 1;
                if iteration.is_multiple_of(stats_every) {
                    let message = stats.message(now, ctl.counters(), true, got_fifo);
                    output.stats(ControlLoopStats { memory_locked, pinned_cpu, ..message });
                }
                next += period;
                let late = Instant::now();
                if next + period < late {
                    // Fell more than a period behind (a stall): restart the schedule from now
                    // instead of bursting through the missed iterations.
                    next = late + period;
                }
            }
            tracing::info!(iterations = iteration, overruns = stats.overruns(), "control loop stopped");
        })?;
        Ok(ControlThread { stop, realtime, handle: Some(handle) })
    }

    /// Whether the thread runs with SCHED_FIFO (false until it has tried).
    pub fn realtime(&self) -> bool {
        self.realtime.load(Ordering::Acquire)
    }

    /// Stops the loop and waits for it (at most about one period).
    pub fn stop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(handle) = self.handle.take()
            && handle.join().is_err()
        {
            tracing::error!("control thread panicked");
        }
    }
}

impl Drop for ControlThread {
    fn drop(&mut self) {
        self.stop();
    }
}
