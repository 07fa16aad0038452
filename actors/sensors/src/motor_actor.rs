//! The motor output actor: actuator commands in, PWM pulses out through the output thread
//! ([`OutputThread`]), which outlives this actor's restarts (kept in a keepsake) so that a
//! failure here never cuts the motors. A `watchdog` timer reports a controller gone quiet while
//! armed (the pulses are held: [`CommandWatchdog`]); a `health_report` timer publishes the
//! writes and failed writes on `health` ([`SensorHealth`], as the other drivers do). A motor
//! without its pulse for `fail_after_s` while armed (the write keeps failing) fails this actor
//! with the reason: the motors actor is flight-critical in `config/navio2.toml`, so that failure
//! is the commander's failsafe (land), while the output thread keeps retrying.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use kestrel_proto::messages::{ActuatorOutputs, SensorHealth};
use kestrel_proto::{Actor, ActorError, Context, Keepsake, Publisher, Setup, Time};
use serde::Deserialize;

use crate::health::{Counters, HealthWindow};
use crate::pwm::{CommandWatchdog, MotorOutput, OutputThread, PulseConfig};

/// `[actors.motors.params]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MotorActorParams {
    /// The PWM class directory (a temporary directory in tests).
    pub root: PathBuf,
    /// `pwmchip` number (Navio2 RCIO: 0).
    pub chip: u32,
    /// PWM channel of motor 1, 2, ... in the frame's motor order.
    pub channels: Vec<u32>,
    pub pulses: PulseConfig,
    /// Silence from the controller after which it is reported (s).
    pub timeout_s: f64,
    /// How long a motor may go without the pulse it should have (its writes failing) while
    /// armed before that is a failure of this actor, and so a failsafe (s). A transient error
    /// (EIO for some milliseconds) is retried every 2.5 ms and stays below it.
    pub fail_after_s: f64,
}

impl Default for MotorActorParams {
    fn default() -> MotorActorParams {
        MotorActorParams {
            root: PathBuf::from("/sys/class/pwm"),
            chip: 0,
            channels: vec![0, 1, 2, 3],
            pulses: PulseConfig::default(),
            timeout_s: 0.1,
            fail_after_s: 0.5,
        }
    }
}

/// What the motor actor handles.
#[derive(Debug)]
pub enum MotorInput {
    /// Port `actuators`.
    Actuators(ActuatorOutputs),
    /// Timer `watchdog`, at a quarter of the timeout.
    Watchdog(Time),
    /// Timer `health_report`, every second.
    Health(Time),
}

/// The outputs before the thread runs, or the thread.
enum Output {
    Opened(MotorOutput),
    Running(Arc<OutputThread>),
}

/// The motor output actor. Output: `health`.
pub struct MotorActor {
    output: Option<Output>,
    keepsake: Keepsake<Arc<OutputThread>>,
    watchdog: CommandWatchdog,
    fail_after: Duration,
    window: Option<HealthWindow>,
    health: Publisher<SensorHealth>,
}

impl MotorActor {
    fn thread(&self) -> Option<&Arc<OutputThread>> {
        match &self.output {
            Some(Output::Running(thread)) => Some(thread),
            _ => None,
        }
    }
}

impl Actor for MotorActor {
    type Params = MotorActorParams;
    type Input = MotorInput;

    fn build(
        params: &MotorActorParams,
        setup: &mut impl Setup<MotorInput>,
    ) -> Result<MotorActor, ActorError> {
        let timeout = kestrel_proto::timing::positive_seconds("timeout_s", params.timeout_s, 60.0)?;
        let fail_after = kestrel_proto::timing::positive_seconds("fail_after_s", params.fail_after_s, 60.0)?;
        let keepsake = setup.keepsake::<Arc<OutputThread>>("output");
        let output = match keepsake.take().filter(|thread| !thread.is_finished()) {
            Some(thread) => {
                tracing::warn!(
                    actor = setup.name(),
                    "restarted: the output thread held the motors at their last pulses"
                );
                keepsake.keep(&thread);
                Output::Running(thread)
            }
            None => {
                let root = setup.config_dir().join(&params.root);
                let motors = MotorOutput::open(
                    &root,
                    params.chip,
                    &params.channels,
                    params.pulses.clone(),
                    &mut std::thread::sleep,
                )
                .map_err(|e| ActorError::Failed(e.to_string()))?;
                Output::Opened(motors)
            }
        };
        setup.input("actuators", MotorInput::Actuators);
        setup.timer("watchdog", timeout / 4, MotorInput::Watchdog);
        setup.timer("health_report", Duration::from_secs(1), MotorInput::Health);
        Ok(MotorActor {
            output: Some(output),
            keepsake,
            watchdog: CommandWatchdog::new(timeout),
            fail_after,
            window: None,
            health: setup.output("health"),
        })
    }

    async fn start(&mut self, ctx: &Context) -> Result<(), ActorError> {
        let thread = match self.output.take() {
            Some(Output::Opened(motors)) => {
                let shutdown = ctx.shutdown().clone();
                let thread = OutputThread::spawn(
                    &format!("{}-output", ctx.name()),
                    motors,
                    Arc::clone(ctx.clock()),
                    move || shutdown.is_cancelled(),
                )
                .map_err(|source| ActorError::Io {
                    what: "cannot start the motor output thread".into(),
                    source,
                })?;
                let thread = Arc::new(thread);
                self.keepsake.keep(&thread);
                thread
            }
            Some(Output::Running(thread)) => thread,
            None => return Err(ActorError::Failed("motor outputs already started".into())),
        };
        self.window = Some(HealthWindow::new(ctx.name(), &thread.device, ctx.now()));
        self.output = Some(Output::Running(thread));
        Ok(())
    }

    async fn handle(&mut self, ctx: &Context, input: MotorInput) -> Result<(), ActorError> {
        let Some(thread) = self.thread().cloned() else {
            return Err(ActorError::Failed("motor outputs not started".into()));
        };
        match input {
            MotorInput::Actuators(outputs) => {
                self.watchdog.on_command(ctx.now(), outputs.armed);
                thread.send(outputs);
            }
            MotorInput::Watchdog(now) => {
                if self.watchdog.check(now) {
                    tracing::warn!(
                        silences = self.watchdog.silences(),
                        "no actuator commands for the timeout while armed: holding the last pulses"
                    );
                }
                let failing = thread.failing_for(now);
                if self.watchdog.armed() && failing > self.fail_after {
                    return Err(ActorError::Failed(format!(
                        "PWM output {}: a motor without its pulse for {:.2} s (writes failing, {} so far; still retrying)",
                        thread.device,
                        failing.as_secs_f64(),
                        thread.counts().errors
                    )));
                }
            }
            MotorInput::Health(now) => {
                let counts = thread.counts();
                if let Some(window) = &mut self.window {
                    let totals = Counters { published: counts.writes, errors: counts.errors, clipped: 0 };
                    let health = window.report(now, totals);
                    if health.errors > 0 {
                        tracing::warn!(errors = health.errors, device = %thread.device, "PWM writes failed in the last second (retried)");
                    }
                    self.health.publish(health);
                }
            }
        }
        Ok(())
    }

    async fn stop(&mut self, ctx: &Context) {
        // Only the graph's shutdown ends the outputs (disarmed); a restart keeps them running.
        if ctx.shutdown().is_cancelled()
            && let Some(thread) = self.thread()
        {
            thread.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::messages::MAX_MOTORS;
    use kestrel_proto::testing::{TestSetup, ready};

    use super::*;
    use crate::pwm::sysfs::tests::FakePwmRoot;

    fn armed(t_us: u64, level: f64) -> ActuatorOutputs {
        ActuatorOutputs { time: Time::from_micros(t_us), armed: true, motors: [level; MAX_MOTORS] }
    }

    fn wait_for(fake: &FakePwmRoot, file: &str, value: &str) {
        for _ in 0..2000 {
            if fake.read(file) == value {
                return;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        panic!("{file} never read {value}: {}", fake.read(file));
    }

    #[test]
    fn drives_the_motors_holds_them_across_a_restart_and_disarms_at_shutdown() {
        let fake = FakePwmRoot::new("actor", 0, &[0, 1, 2, 3]);
        let params = MotorActorParams { root: fake.root.clone(), ..MotorActorParams::default() };
        let mut setup = TestSetup::new("motors", "/");
        let mut actor = MotorActor::build(&params, &mut setup).expect("build");
        assert_eq!(
            setup.timers(),
            [("watchdog", Duration::from_millis(25)), ("health_report", Duration::from_secs(1))]
        );
        let ctx = setup.context();
        setup.manual_clock().set(Time::from_micros(1_000_000));
        ready(actor.start(&ctx)).expect("start");
        ready(actor.handle(&ctx, setup.input("actuators", armed(1_000_000, 0.25)))).expect("apply");
        wait_for(&fake, "pwmchip0/pwm2/duty_cycle", "1250000");
        ready(actor.handle(&ctx, setup.tick("watchdog", Time::from_micros(1_200_000)))).expect("watchdog");
        assert_eq!(fake.read("pwmchip0/pwm2/duty_cycle"), "1250000", "held, not cut");

        // The actor fails and the supervisor builds it again: the motors keep their pulses.
        drop(actor);
        std::thread::sleep(Duration::from_millis(20));
        assert_eq!(fake.read("pwmchip0/pwm2/duty_cycle"), "1250000", "a restart does not disarm");
        let mut actor = MotorActor::build(&params, &mut setup).expect("build again");
        ready(actor.start(&ctx)).expect("start again");
        assert_eq!(fake.read("pwmchip0/pwm2/duty_cycle"), "1250000", "nor does the successor's start");
        ready(actor.handle(&ctx, setup.input("actuators", armed(1_300_000, 0.5)))).expect("apply");
        wait_for(&fake, "pwmchip0/pwm0/duty_cycle", "1500000");

        let now = Time::from_micros(2_000_000);
        setup.manual_clock().set(now);
        ready(actor.handle(&ctx, setup.tick("health_report", now))).expect("health");
        let health: Vec<SensorHealth> = setup.published("health");
        assert_eq!(health.len(), 1);
        assert_eq!(health[0].errors, 0, "{:?}", health[0]);
        assert!(health[0].device.ends_with("pwmchip0"), "{:?}", health[0]);

        ctx.shutdown().cancel();
        ready(actor.stop(&ctx));
        assert_eq!(fake.read("pwmchip0/pwm0/duty_cycle"), "1000000", "disarmed at shutdown");
    }

    #[test]
    fn a_missing_pwm_chip_names_its_path() {
        let fake = FakePwmRoot::new("actor-missing", 0, &[]);
        let params = MotorActorParams { root: fake.root.clone(), chip: 7, ..MotorActorParams::default() };
        let err = MotorActor::build(&params, &mut TestSetup::new("motors", "/")).err().expect("no chip");
        assert!(err.to_string().contains("pwmchip7/export"), "{err}");
    }
}
