//! The control loop on its own OS thread (hardware, realtime clock). Like PX4's rate loop,
//! which runs on each gyro sample, it runs on each new NavState: the actor writes the NavState
//! into a triple buffer and unparks the thread. When none arrives within
//! [`WATCHDOG_PERIODS`] periods the watchdog runs the iteration instead (the last commands
//! re-stamped while the newest NavState is younger than the timeout, flying blind after it), so
//! the motors never go without a command; without a fresh NavState it flies on the backup
//! attitude, fed every IMU sample through a ring and the newest compass and barometer samples
//! (`FlightController::fly_without_nav`). Each iteration takes the newest gains and setpoint,
//! hands the motor commands to `output` and pushes its timing; the statistics are made elsewhere.
//! It never waits on tokio or a lock, and allocates nothing per iteration; it ends when told to
//! or when the actor that feeds it is gone.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use kestrel_proto::Clock;
use kestrel_proto::messages::{ActuatorOutputs, BaroSample, MagSample, NavState, Setpoint};
use kestrel_proto::time::duration_micros;

use super::affinity::pin_to_cpu;
use super::memory::lock_memory;
use super::sample_ring::RingReader;
use super::triple_buffer::Reader;
use crate::backup_attitude::ImuReading;
use crate::flight_controller::{FlightController, LoopCounters};
use crate::live_params::Gains;
use kestrel_proto::realtime::{RealtimePriority, set_realtime_priority};

/// Periods without a NavState after which the watchdog runs an iteration: half a period of
/// jitter is tolerated before the loop acts on its own.
pub const WATCHDOG_PERIODS: f64 = 1.5;

/// One iteration's timing, handed to the statistics side.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LoopSample {
    /// Wall-clock start since the loop began (µs).
    pub start_us: u64,
    /// Wall-clock time the iteration took (µs).
    pub execution_us: u64,
    /// Age of the NavState it ran on when it started (µs of graph time since the NavState's
    /// measurement); `None` when the watchdog started it.
    pub nav_age_us: Option<u64>,
}

/// What the OS granted the loop thread, told once before the first iteration.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Granted {
    pub sched_fifo: bool,
    pub memory_locked: bool,
    pub pinned_cpu: Option<u32>,
}

/// What the thread hands out. Called on the real-time thread, so an implementation must not
/// lock or allocate: the actor writes into triple buffers and a sample ring, and a tokio task
/// publishes from them (at most about one period later).
pub trait ThreadOutput: Send + 'static {
    fn granted(&mut self, granted: Granted);
    fn actuators(&mut self, outputs: &ActuatorOutputs);
    /// The backup attitude's state, after an iteration that flew on it.
    fn backup_nav(&mut self, nav: &NavState);
    /// Once per iteration, after `actuators`.
    fn record(&mut self, sample: LoopSample, counters: LoopCounters);
}

/// The triple buffers the thread reads each period.
pub struct ThreadInputs {
    pub nav: Reader<Option<NavState>>,
    pub setpoint: Reader<Option<Setpoint>>,
    /// New gains, already validated by the actor (see [`crate::live_params`]).
    pub gains: Reader<Option<Gains>>,
    /// Every IMU sample, for the backup attitude.
    pub imu: RingReader<ImuReading>,
    pub mag: Reader<Option<MagSample>>,
    pub baro: Reader<Option<BaroSample>>,
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
    handle: Option<JoinHandle<()>>,
}

impl ControlThread {
    /// Starts the loop at `ctl.params().timing.rate_hz` with what `os` asks for, where permitted.
    pub fn spawn(
        ctl: FlightController,
        inputs: ThreadInputs,
        clock: Arc<dyn Clock>,
        mut output: impl ThreadOutput,
        os: RealtimeSettings,
    ) -> std::io::Result<ControlThread> {
        let stop = Arc::new(AtomicBool::new(false));
        let stop_flag = Arc::clone(&stop);
        let handle = std::thread::Builder::new().name("kestrel-control".into()).spawn(move || {
            output.granted(ask_the_os(os));
            run(ctl, inputs, clock.as_ref(), &mut output, &stop_flag);
        })?;
        Ok(ControlThread { stop, handle: Some(handle) })
    }

    /// Tells the thread a NavState is waiting (after it was written): wakes it if it waits.
    pub fn wake(&self) {
        if let Some(handle) = &self.handle {
            handle.thread().unpark();
        }
    }

    /// Stops the loop and waits for it (at most about one period).
    pub fn stop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(handle) = self.handle.take() {
            handle.thread().unpark();
            if handle.join().is_err() {
                tracing::error!("control thread panicked");
            }
        }
    }
}

/// Memory lock, CPU pinning and SCHED_FIFO, each asked for, logged, and reported.
fn ask_the_os(os: RealtimeSettings) -> Granted {
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
    let sched_fifo = match set_realtime_priority(os.priority) {
        RealtimePriority::Fifo(p) => {
            tracing::info!(priority = p, "control loop on a SCHED_FIFO thread");
            true
        }
        RealtimePriority::Normal(why) => {
            tracing::warn!(%why, "control loop on a normal-priority thread");
            false
        }
    };
    Granted { sched_fifo, memory_locked, pinned_cpu }
}

/// The loop: wait for a NavState or the watchdog, run one iteration, repeat.
fn run(
    mut ctl: FlightController,
    inputs: ThreadInputs,
    clock: &dyn Clock,
    output: &mut impl ThreadOutput,
    stop: &AtomicBool,
) {
    let ThreadInputs { mut nav, mut setpoint, mut gains, mut imu, mut mag, mut baro } = inputs;
    let timing = ctl.params().timing.clone();
    let watchdog = Duration::from_secs_f64(WATCHDOG_PERIODS / timing.rate_hz);
    let origin = Instant::now();
    let mut last_start = origin;
    let mut last = ActuatorOutputs::default();
    let mut iterations = 0u64;
    while !stop.load(Ordering::Acquire) && !nav.writer_gone() {
        let deadline = last_start + watchdog;
        while !nav.has_fresh() && !stop.load(Ordering::Acquire) {
            let now_wall = Instant::now();
            if now_wall >= deadline {
                break;
            }
            // Woken early by `ControlThread::wake`; a spurious wake-up just checks again.
            std::thread::park_timeout(deadline - now_wall);
        }
        let started = Instant::now();
        let now = clock.now();
        if let (Some(g), true) = gains.read() {
            ctl.retune(g);
        }
        if let (Some(m), true) = mag.read() {
            ctl.on_mag(m);
        }
        if let (Some(b), true) = baro.read() {
            ctl.on_baro(b);
        }
        imu.drain(|sample| ctl.on_imu(&sample));
        if let (Some(sp), true) = setpoint.read() {
            // A refused setpoint is counted by the controller and the last good one kept.
            let _ = ctl.set_setpoint(sp);
        }
        let mut nav_age_us = None;
        last = match nav.read() {
            (Some(n), fresh) if now.saturating_since(n.time).as_secs_f64() <= timing.nav_timeout_s => {
                if fresh {
                    nav_age_us = Some(duration_micros(now.saturating_since(n.time)));
                    ctl.update(n)
                } else {
                    ActuatorOutputs { time: now, ..last }
                }
            }
            _ => ctl.fly_without_nav(now),
        };
        output.actuators(&last);
        if let Some(backup) = ctl.flown_backup() {
            output.backup_nav(backup);
        }
        let sample = LoopSample {
            start_us: duration_micros(started - origin),
            execution_us: duration_micros(started.elapsed()),
            nav_age_us,
        };
        output.record(sample, ctl.counters());
        iterations += 1;
        last_start = started;
    }
    tracing::info!(iterations, "control loop stopped");
}

impl Drop for ControlThread {
    fn drop(&mut self) {
        self.stop();
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Mutex;

    use kestrel_proto::Time;
    use kestrel_proto::messages::{SetpointTarget, TrajectorySetpoint};
    use kestrel_proto::testing::ManualClock;

    use super::*;
    use crate::params::ControlParams;
    use crate::rt::sample_ring::{RingWriter, sample_ring};
    use crate::rt::triple_buffer::{Writer, triple_buffer};

    /// What the thread handed out, shared with the test (a test may lock; the loop's real
    /// output does not).
    #[derive(Default)]
    struct Seen {
        granted: Option<Granted>,
        outputs: Vec<ActuatorOutputs>,
        backup: Vec<NavState>,
        samples: Vec<(LoopSample, LoopCounters)>,
    }

    struct Recording(Arc<Mutex<Seen>>);

    impl ThreadOutput for Recording {
        fn granted(&mut self, granted: Granted) {
            self.0.lock().expect("seen").granted = Some(granted);
        }
        fn actuators(&mut self, outputs: &ActuatorOutputs) {
            self.0.lock().expect("seen").outputs.push(outputs.clone());
        }
        fn backup_nav(&mut self, nav: &NavState) {
            self.0.lock().expect("seen").backup.push(nav.clone());
        }
        fn record(&mut self, sample: LoopSample, counters: LoopCounters) {
            self.0.lock().expect("seen").samples.push((sample, counters));
        }
    }

    struct Bench {
        thread: ControlThread,
        nav: Writer<Option<NavState>>,
        _setpoint: Writer<Option<Setpoint>>,
        _gains: Writer<Option<Gains>>,
        imu: RingWriter<ImuReading>,
        _mag: Writer<Option<MagSample>>,
        _baro: Writer<Option<BaroSample>>,
        clock: Arc<ManualClock>,
        seen: Arc<Mutex<Seen>>,
    }

    /// A loop hovering at 10 m on a manual clock, asking the OS for nothing.
    fn bench() -> Bench {
        let ctl = FlightController::new(ControlParams::default()).expect("default params");
        let (nav, nav_reader) = triple_buffer(None);
        let (mut setpoint, setpoint_reader) = triple_buffer(None);
        let (gains, gains_reader) = triple_buffer(None);
        let (imu, imu_reader) = sample_ring(64, ImuReading::default());
        let (mag, mag_reader) = triple_buffer(None);
        let (baro, baro_reader) = triple_buffer(None);
        setpoint.write(Some(Setpoint {
            time: Time(0),
            armed: true,
            target: SetpointTarget::Trajectory(TrajectorySetpoint {
                position_ned_m: [Some(0.0), Some(0.0), Some(-10.0)],
                ..TrajectorySetpoint::default()
            }),
            landing: false,
            failed_motor: None,
        }));
        let clock = Arc::new(ManualClock::default());
        let seen = Arc::new(Mutex::new(Seen::default()));
        let inputs = ThreadInputs {
            nav: nav_reader,
            setpoint: setpoint_reader,
            gains: gains_reader,
            imu: imu_reader,
            mag: mag_reader,
            baro: baro_reader,
        };
        let os = RealtimeSettings { priority: 1, lock_memory: false, cpu: None };
        let thread = ControlThread::spawn(ctl, inputs, clock.clone(), Recording(Arc::clone(&seen)), os)
            .expect("spawn");
        Bench { thread, nav, _setpoint: setpoint, _gains: gains, imu, _mag: mag, _baro: baro, clock, seen }
    }

    fn nav_at(us: u64) -> NavState {
        NavState::exact(Time(us), [1.0, 0.0, 0.0, 0.0], [0.0; 3], [0.0; 3], [0.0, 0.0, -10.0])
    }

    /// Waits (up to 10 s) until `done` holds for what the thread handed out.
    fn wait_for(seen: &Mutex<Seen>, done: impl Fn(&Seen) -> bool) {
        let until = Instant::now() + Duration::from_secs(10);
        while !done(&seen.lock().expect("seen")) {
            assert!(Instant::now() < until, "the control thread did not get there within 10 s");
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    #[test]
    fn each_navstate_runs_exactly_one_iteration_on_it() {
        let mut b = bench();
        for k in 1..=50u64 {
            let t = k * 2500;
            b.clock.set(Time(t + 300));
            b.nav.write(Some(nav_at(t)));
            b.thread.wake();
            wait_for(&b.seen, |s| s.outputs.iter().any(|o| o.time == Time(t) && o.armed));
        }
        b.thread.stop();
        let seen = b.seen.lock().expect("seen");
        let on_nav: Vec<_> = seen.samples.iter().filter_map(|(s, _)| s.nav_age_us).collect();
        assert_eq!(on_nav.len(), 50, "one iteration per NavState, none run twice on the same one");
        assert!(on_nav.iter().all(|&age| age == 300), "the age is the clock's now less the NavState's time");
        let granted = seen.granted.expect("told before the first iteration");
        assert!(!granted.memory_locked && granted.pinned_cpu.is_none(), "neither was asked for");
        assert!(seen.outputs.iter().all(|o| o.motors.iter().all(|m| (0.0..=1.0).contains(m))));
    }

    #[test]
    fn without_navstates_the_watchdog_keeps_commanding_then_flies_blind() {
        let mut b = bench();
        b.clock.set(Time(1_000));
        b.nav.write(Some(nav_at(1_000)));
        b.thread.wake();
        // The NavState stays young: the watchdog re-stamps the last commands.
        wait_for(&b.seen, |s| s.samples.iter().filter(|(x, _)| x.nav_age_us.is_none()).count() >= 5);
        {
            let seen = b.seen.lock().expect("seen");
            assert_eq!(seen.samples.iter().filter(|(x, _)| x.nav_age_us.is_some()).count(), 1);
            assert!(
                seen.samples.iter().all(|(_, c)| c.blind_steps == 0),
                "not blind while the NavState is fresh"
            );
            let first = seen.outputs[0].motors;
            assert!(seen.outputs.iter().all(|o| o.motors == first && o.armed), "the last commands held");
        }
        // Older than `nav_timeout_s`: blind (level, a little below hover), still armed.
        b.clock.set(Time(1_000 + 60_000));
        wait_for(&b.seen, |s| s.samples.last().is_some_and(|(_, c)| c.blind_steps >= 5));
        b.thread.stop();
        let seen = b.seen.lock().expect("seen");
        let last = seen.outputs.last().expect("outputs");
        assert!(last.armed && last.time == Time(61_000));
    }

    #[test]
    fn when_navstates_stop_the_thread_flies_on_the_backup_attitude() {
        let mut b = bench();
        let push = |b: &mut Bench, from: u64, to: u64| {
            for k in from..to {
                let time = Time(k * 2500);
                let reading = ImuReading { time, accel_m_s2: [0.0, 0.0, -9.80665], ..ImuReading::default() };
                while !b.imu.push(reading) {
                    std::thread::sleep(Duration::from_micros(200));
                }
                b.clock.set(time);
            }
        };
        // 2.4 s of IMU samples at rest, level: the backup aligns (2 s); then one NavState, flown.
        push(&mut b, 0, 961);
        let at = Time(960 * 2500);
        b.nav.write(Some(nav_at(at.0)));
        b.thread.wake();
        wait_for(&b.seen, |s| s.outputs.iter().any(|o| o.time == at));
        assert!(b.seen.lock().expect("seen").backup.is_empty(), "the estimator's state flew");
        // No NavState after it: past `nav_timeout_s` the backup flies.
        push(&mut b, 961, 1000);
        wait_for(&b.seen, |s| s.samples.last().is_some_and(|(_, c)| c.backup_steps >= 5));
        b.thread.stop();
        let seen = b.seen.lock().expect("seen");
        let nav = seen.backup.last().expect("the backup's state handed out");
        assert!(nav.valid.attitude && !nav.valid.horizontal_position);
        assert_eq!(nav.time, Time(999 * 2500), "the newest IMU sample's time");
        assert!(
            (nav.position_ned_m[2] + 10.0).abs() < 1e-9,
            "on the estimator's height: {:?}",
            nav.position_ned_m
        );
        assert!(seen.outputs.last().is_some_and(|o| o.armed));
    }
}
