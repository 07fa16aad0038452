//! Period, execution-time and NavState-age statistics of the control loop, in fixed histograms
//! (1 µs bins up to 50 ms, everything above in the last bin), so recording never allocates. On
//! the real-time thread these are kept by the tokio side from the loop's samples
//! (`sample_ring.rs`): the quantile scans never run on the loop's thread.

use kestrel_proto::Time;
use kestrel_proto::messages::ControlLoopStats;

use super::thread::{Granted, LoopSample};
use crate::flight_controller::LoopCounters;

const BINS: usize = 50_000;

/// A latency histogram in whole microseconds.
#[derive(Clone, Debug)]
pub struct Histogram {
    counts: Box<[u32]>,
    total: u64,
    max_us: u64,
}

impl Default for Histogram {
    fn default() -> Histogram {
        Histogram { counts: vec![0; BINS].into_boxed_slice(), total: 0, max_us: 0 }
    }
}

impl Histogram {
    pub fn record(&mut self, us: u64) {
        let bin = usize::try_from(us).unwrap_or(BINS - 1).min(BINS - 1);
        self.counts[bin] = self.counts[bin].saturating_add(1);
        self.total += 1;
        self.max_us = self.max_us.max(us);
    }

    /// The `q` quantile (0..1) in µs; 0 when empty.
    pub fn quantile_us(&self, q: f64) -> f64 {
        if self.total == 0 {
            return 0.0;
        }
        let rank = ((q.clamp(0.0, 1.0) * self.total as f64).ceil() as u64).max(1);
        let mut seen = 0u64;
        for (us, &c) in self.counts.iter().enumerate() {
            seen += u64::from(c);
            if seen >= rank {
                return us as f64;
            }
        }
        self.max_us as f64
    }

    pub fn max_us(&self) -> f64 {
        self.max_us as f64
    }

    pub fn count(&self) -> u64 {
        self.total
    }
}

/// The loop's timing record.
#[derive(Clone, Debug)]
pub struct LoopStats {
    nominal_us: u64,
    period: Histogram,
    execution: Histogram,
    nav_age: Histogram,
    overruns: u64,
    watchdog_steps: u64,
    last_start: Option<u64>,
    /// Whether an iteration that executes longer than the period is an overrun: on the real-time
    /// thread it is (the next deadline is missed); in lockstep the simulated clock waits for the
    /// loop, so host execution time (a busy CI machine, a debugger) misses no deadline and is
    /// only recorded.
    execution_deadline: bool,
}

impl LoopStats {
    /// Statistics for a loop meant to run every `nominal_us` microseconds.
    pub fn new(nominal_us: u64) -> LoopStats {
        LoopStats {
            nominal_us,
            period: Histogram::default(),
            execution: Histogram::default(),
            nav_age: Histogram::default(),
            overruns: 0,
            watchdog_steps: 0,
            last_start: None,
            execution_deadline: true,
        }
    }

    /// Statistics for a loop stepped by the lockstep clock: overruns are late periods on the
    /// graph clock only (see `execution_deadline`).
    pub fn lockstep(nominal_us: u64) -> LoopStats {
        LoopStats { execution_deadline: false, ..LoopStats::new(nominal_us) }
    }

    /// Records one iteration.
    pub fn record(&mut self, sample: LoopSample) {
        let LoopSample { start_us, execution_us, nav_age_us } = sample;
        match nav_age_us {
            Some(age) => self.nav_age.record(age),
            None => self.watchdog_steps += 1,
        }
        if let Some(last) = self.last_start {
            let period = start_us.saturating_sub(last);
            self.period.record(period);
            if period > self.nominal_us + self.nominal_us / 2 {
                self.overruns += 1;
            }
        }
        if self.execution_deadline && execution_us > self.nominal_us {
            self.overruns += 1;
        }
        self.execution.record(execution_us);
        self.last_start = Some(start_us);
    }

    pub fn period(&self) -> &Histogram {
        &self.period
    }

    pub fn execution(&self) -> &Histogram {
        &self.execution
    }

    pub fn overruns(&self) -> u64 {
        self.overruns
    }

    /// The message form, with the controller's counters, what the OS granted the loop's thread
    /// (`None`: no thread, lockstep) and samples lost before they reached these statistics.
    pub fn message(
        &self,
        time: Time,
        counters: LoopCounters,
        thread: Option<Granted>,
        dropped_samples: u64,
    ) -> ControlLoopStats {
        let granted = thread.unwrap_or_default();
        ControlLoopStats {
            time,
            dedicated_thread: thread.is_some(),
            realtime_priority: granted.sched_fifo,
            memory_locked: granted.memory_locked,
            pinned_cpu: granted.pinned_cpu,
            iterations: self.execution.count(),
            period_p50_us: self.period.quantile_us(0.5),
            period_p99_us: self.period.quantile_us(0.99),
            period_max_us: self.period.max_us(),
            execution_p50_us: self.execution.quantile_us(0.5),
            execution_p99_us: self.execution.quantile_us(0.99),
            execution_max_us: self.execution.max_us(),
            overruns: self.overruns,
            nav_age_p50_us: self.nav_age.quantile_us(0.5),
            nav_age_p99_us: self.nav_age.quantile_us(0.99),
            watchdog_steps: self.watchdog_steps,
            dropped_samples,
            rejected_setpoints: counters.rejected_setpoints,
            rejected_nav: counters.rejected_nav,
            blind_steps: counters.blind_steps,
            lost_setpoint_steps: counters.lost_setpoint_steps,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(start_us: u64, execution_us: u64) -> LoopSample {
        LoopSample { start_us, execution_us, nav_age_us: Some(0) }
    }

    #[test]
    fn lockstep_loops_count_late_periods_but_not_slow_host_execution() {
        let mut s = LoopStats::lockstep(2500);
        s.record(sample(0, 9000));
        s.record(sample(2500, 100));
        assert_eq!(s.overruns(), 0, "a slow host step misses no simulated deadline");
        s.record(sample(9000, 100));
        assert_eq!(s.overruns(), 1, "a late period on the graph clock does");
    }

    #[test]
    fn nav_ages_and_watchdog_steps_reach_the_message() {
        let mut s = LoopStats::new(2500);
        for i in 0..99u64 {
            s.record(LoopSample { start_us: i * 2500, execution_us: 30, nav_age_us: Some(400 + i % 3) });
        }
        s.record(LoopSample { start_us: 99 * 2500 + 1250, execution_us: 30, nav_age_us: None });
        let granted = Granted { sched_fifo: true, memory_locked: false, pinned_cpu: Some(3) };
        let m = s.message(Time::from_micros(1), LoopCounters::default(), Some(granted), 2);
        assert_eq!((m.nav_age_p50_us, m.nav_age_p99_us), (401.0, 402.0));
        assert_eq!((m.watchdog_steps, m.dropped_samples, m.iterations), (1, 2, 100));
        assert!(m.dedicated_thread && m.realtime_priority && !m.memory_locked);
        assert_eq!(m.pinned_cpu, Some(3));
        let lockstep = s.message(Time::from_micros(1), LoopCounters::default(), None, 0);
        assert!(!lockstep.dedicated_thread && !lockstep.realtime_priority);
    }

    #[test]
    fn quantiles_and_overruns() {
        let mut s = LoopStats::new(2500);
        for i in 0..100u64 {
            s.record(sample(i * 2500 + if i == 50 { 2000 } else { 0 }, 40 + i % 2));
        }
        assert_eq!(s.period().quantile_us(0.5), 2500.0);
        assert_eq!(s.period().max_us(), 4500.0);
        assert_eq!(s.overruns(), 1);
        assert_eq!(s.execution().quantile_us(0.99), 41.0);
    }
}
