//! The control loop's own account of its timing and the inputs it refused.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// Published by the controller about once a second: cumulative since it started.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ControlLoopStats {
    pub time: Time,
    /// True when the loop runs on its own OS thread (hardware); false in lockstep.
    pub dedicated_thread: bool,
    /// True when that thread got real-time (SCHED_FIFO) priority.
    pub realtime_priority: bool,
    /// True when the process's memory is locked into RAM (`mlockall`) for the loop.
    #[serde(default)]
    pub memory_locked: bool,
    /// The CPU the loop thread is pinned to, when pinning was asked for and granted.
    #[serde(default)]
    pub pinned_cpu: Option<u32>,
    /// Loop iterations so far.
    pub iterations: u64,
    /// Time between iteration starts (µs): on the thread, wall-clock; in lockstep, between
    /// the NavStates that drove it (graph time).
    pub period_p50_us: f64,
    pub period_p99_us: f64,
    pub period_max_us: f64,
    /// Wall-clock time one iteration took (µs).
    pub execution_p50_us: f64,
    pub execution_p99_us: f64,
    pub execution_max_us: f64,
    /// Iterations that started more than half a period late, or took longer than a period.
    pub overruns: u64,
    /// Age of the NavState an iteration ran on when it started (µs since its IMU sample was
    /// measured: driver, estimator, routing and wake-up together); 0 in lockstep.
    #[serde(default)]
    pub nav_age_p50_us: f64,
    #[serde(default)]
    pub nav_age_p99_us: f64,
    /// Iterations started without a new NavState (the thread's watchdog, the lockstep tick).
    #[serde(default)]
    pub watchdog_steps: u64,
    /// Timing samples the statistics side could not take in time (not counted above).
    #[serde(default)]
    pub dropped_samples: u64,
    /// Setpoints refused (non-finite, out of range).
    pub rejected_setpoints: u64,
    /// NavStates refused (non-finite).
    pub rejected_nav: u64,
    /// Iterations flown without a usable NavState (level and descend).
    pub blind_steps: u64,
    /// Iterations flown on the lost-setpoint fallback.
    pub lost_setpoint_steps: u64,
}
crate::impl_message!(ControlLoopStats);
