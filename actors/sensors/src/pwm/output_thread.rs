//! The motor outputs on a thread of their own: the actor hands each command over and returns at
//! once; the thread writes the pulses (blocking sysfs writes that reach the RCIO co-processor
//! over SPI, some 1600 a second at 400 Hz on four motors — not work for a tokio worker), retries
//! a failed write every [`RETRY_PERIOD`] until it takes, and counts what it did.
//!
//! The thread outlives an actor restart (the actor keeps it in a keepsake), so a failure of the
//! actor never reaches the motors: they keep their last pulses until the successor sends new
//! ones. Only the graph's shutdown ends the thread, which then writes the disarmed pulse.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use kestrel_proto::{Clock, Time};

use crate::pwm::motor_output::{MotorOutput, PwmOut};
use crate::pwm::pulses::PulseCommand;

/// Interval of retries of a failed write, and of checks for shutdown: the 400 Hz loop's period.
pub const RETRY_PERIOD: Duration = Duration::from_micros(2500);

/// What the actor and the thread share.
#[derive(Debug, Default)]
struct Shared {
    /// The newest command not yet written (a newer one replaces it: only the latest matters).
    next: Mutex<Option<PulseCommand>>,
    wake: Condvar,
    writes: AtomicU64,
    errors: AtomicU64,
    /// Graph time (µs) since which a channel has been failing; 0 = none is.
    failing_since_us: AtomicU64,
}

/// What the thread has done so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OutputCounts {
    /// Successful channel writes.
    pub writes: u64,
    /// Failed channel writes (each retried).
    pub errors: u64,
}

/// The running output thread.
#[derive(Debug)]
pub struct OutputThread {
    shared: Arc<Shared>,
    handle: Mutex<Option<JoinHandle<()>>>,
    /// The `duty_cycle` files, for reports.
    pub device: String,
}

impl OutputThread {
    /// Starts the thread `name` writing `motors`, stamping with `clock`, until `stop` says so.
    pub fn spawn<C: PwmOut>(
        name: &str,
        mut motors: MotorOutput<C>,
        clock: Arc<dyn Clock>,
        stop: impl Fn() -> bool + Send + 'static,
    ) -> std::io::Result<OutputThread> {
        // `<root>/pwmchipN/pwmM/duty_cycle` → `<root>/pwmchipN`.
        let device = motors
            .paths()
            .next()
            .and_then(|p| p.parent()?.parent())
            .map_or_else(String::new, |p| p.display().to_string());
        let shared = Arc::new(Shared::default());
        let thread_shared = Arc::clone(&shared);
        let handle = std::thread::Builder::new().name(name.to_owned()).spawn(move || {
            let shared = thread_shared;
            while !stop() {
                let next = {
                    let slot = shared.next.lock().unwrap_or_else(|e| e.into_inner());
                    let (mut slot, _) = shared
                        .wake
                        .wait_timeout_while(slot, RETRY_PERIOD, |next| next.is_none())
                        .unwrap_or_else(|e| e.into_inner());
                    slot.take()
                };
                let now = clock.now();
                match next {
                    Some(command) => motors.apply(&command, now),
                    None => motors.retry(now),
                }
                let (writes, errors) = motors.counts();
                shared.writes.store(writes, Ordering::Relaxed);
                shared.errors.store(errors, Ordering::Relaxed);
                let since = motors.failing_since().map_or(0, |t| t.as_micros().max(1));
                shared.failing_since_us.store(since, Ordering::Relaxed);
            }
            motors.disarm(clock.now());
        })?;
        Ok(OutputThread { shared, handle: Mutex::new(Some(handle)), device })
    }

    /// Hands `command` to the thread (replacing one it has not taken yet); never waits for a
    /// write.
    pub fn send(&self, command: PulseCommand) {
        *self.shared.next.lock().unwrap_or_else(|e| e.into_inner()) = Some(command);
        self.shared.wake.notify_one();
    }

    /// What the thread has written and failed to write so far.
    pub fn counts(&self) -> OutputCounts {
        OutputCounts {
            writes: self.shared.writes.load(Ordering::Relaxed),
            errors: self.shared.errors.load(Ordering::Relaxed),
        }
    }

    /// How long some motor has been without the pulse it should have, at `now`.
    pub fn failing_for(&self, now: Time) -> Duration {
        match self.shared.failing_since_us.load(Ordering::Relaxed) {
            0 => Duration::ZERO,
            since => Duration::from_micros(now.as_micros().saturating_sub(since)),
        }
    }

    /// Whether the thread has ended (it only does at shutdown, or if it panicked).
    pub fn is_finished(&self) -> bool {
        self.handle.lock().unwrap_or_else(|e| e.into_inner()).as_ref().is_none_or(JoinHandle::is_finished)
    }

    /// Waits for the thread to end (after its `stop` said so): the motors are disarmed.
    pub fn join(&self) {
        let handle = self.handle.lock().unwrap_or_else(|e| e.into_inner()).take();
        if let Some(handle) = handle
            && handle.join().is_err()
        {
            tracing::error!("the motor output thread panicked");
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::AtomicBool;

    use kestrel_proto::messages::MAX_MOTORS;
    use kestrel_proto::testing::ManualClock;

    use super::*;
    use crate::pwm::PulseConfig;
    use crate::pwm::motor_output::tests::FakeChannel;

    fn command(armed: bool, level: f64) -> PulseCommand {
        let outputs =
            kestrel_proto::messages::ActuatorOutputs { time: Time::ZERO, armed, motors: [level; MAX_MOTORS] };
        let config = PulseConfig::default();
        crate::pwm::pulse_widths_us(&outputs, &config, &config.ranges())
    }

    fn wait_until(what: &str, done: impl Fn() -> bool) {
        for _ in 0..2000 {
            if done() {
                return;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        panic!("never: {what}");
    }

    #[test]
    fn writes_commands_retries_failures_and_disarms_only_at_shutdown() {
        let channels: Vec<FakeChannel> = (0..4).map(|_| FakeChannel::default()).collect();
        let motors = MotorOutput::on_channels(channels.clone(), PulseConfig::default()).expect("outputs");
        let clock = Arc::new(ManualClock::default());
        clock.set(Time::from_micros(1_000_000));
        let stop = Arc::new(AtomicBool::new(false));
        let stop_flag = Arc::clone(&stop);
        let thread = OutputThread::spawn("motors-test", motors, clock.clone(), move || {
            stop_flag.load(Ordering::Relaxed)
        })
        .expect("spawn");
        thread.send(command(true, 0.5));
        wait_until("the command is written", || channels[3].last_ns() == Some(1_500_000));

        channels[0].fail(true);
        thread.send(command(true, 0.6));
        wait_until("the failure is counted", || thread.counts().errors >= 2);
        clock.set(Time::from_micros(1_050_000));
        wait_until("the failure's age is known", || thread.failing_for(clock.now()) > Duration::ZERO);
        assert_eq!(channels[0].last_ns(), Some(1_500_000), "held at its last pulse, not cut");
        channels[0].fail(false);
        wait_until("retried without a new command", || channels[0].last_ns() == Some(1_600_000));
        wait_until("no longer failing", || thread.failing_for(clock.now()).is_zero());

        stop.store(true, Ordering::Relaxed);
        thread.join();
        assert!(thread.is_finished());
        assert!(channels.iter().all(|c| c.last_ns() == Some(1_000_000)), "disarmed at shutdown");
    }
}
