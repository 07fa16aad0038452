//! The motor output actor: actuator commands in, PWM pulses out through the output thread
//! ([`OutputThread`]), which outlives this actor's restarts (kept in a keepsake) so that a
//! failure here never cuts the motors. A `watchdog` timer reports a controller gone quiet while
//! armed (the pulses are held: [`CommandWatchdog`]); a `health_report` timer publishes the
//! writes and failed writes on `health` ([`SensorHealth`], as the other drivers do). A motor
//! without its pulse for `fail_after_s` while armed (the write keeps failing) fails this actor
//! with the reason: the motors actor is flight-critical in `config/navio2.toml`, so that failure
//! is the commander's failsafe (land), while the output thread keeps retrying.
//!
//! It maps each command onto its output's pulse range, the live `SERVOn_MIN`/`SERVOn_MAX` it
//! owns and declares (`param_set` in, `param_decl` out; `pulses.min_us`/`max_us` until set, as
//! an ESC range calibration sets them; refused while armed, `WhileArmed::Locked`), and takes direct pulses while disarmed (`esc_pulses`,
//! an ESC calibration's ramp), checked and dropped after 0.1 s by
//! [`DirectPulses`](kestrel_proto::esc::DirectPulses): the disarmed pulse again.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use kestrel_proto::esc::{DirectPulses, EscRanges, esc_range_params};
use kestrel_proto::messages::{ActuatorOutputs, EscPulses, ParamDecl, ParamSet, SensorHealth};
use kestrel_proto::param_def::{answer, apply_set, declare};
use kestrel_proto::{Actor, ActorError, Context, Keepsake, Publisher, Setup, Time};
use serde::Deserialize;

use crate::health::{Counters, HealthWindow};
use crate::pwm::{CommandWatchdog, MotorOutput, OutputThread, PulseCommand, PulseConfig, pulse_widths_us};

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
    /// Port `esc_pulses`: direct pulses while disarmed.
    Pulses(EscPulses),
    /// Port `param_set`: `SERVOn_MIN`/`SERVOn_MAX` (others' names are ignored).
    Param(ParamSet),
}

/// The outputs before the thread runs, or the thread.
enum Output {
    Opened(MotorOutput),
    Running(Arc<OutputThread>),
}

/// The motor output actor. Outputs: `health`, `param_decl`.
pub struct MotorActor {
    pulses: PulseConfig,
    ranges: EscRanges,
    /// How many outputs drive motors (their ranges are declared).
    outputs: usize,
    direct: DirectPulses,
    /// Whether the newest actuator command armed the motors.
    armed: bool,
    /// Whether direct pulses were written last (so their timeout writes the disarmed pulse).
    direct_written: bool,
    param_decl: Publisher<ParamDecl>,
    name: String,
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

impl MotorActor {
    /// While disarmed: the direct pulses when fresh, else the disarmed pulse.
    fn write_direct_or_disarmed(&mut self, thread: &OutputThread, now: Time) {
        let command = match self.direct.pulses_us(now, false) {
            Some(pulses_us) => PulseCommand::direct(pulses_us),
            None => PulseCommand::disarmed(&self.pulses),
        };
        self.direct_written = command != PulseCommand::disarmed(&self.pulses);
        thread.send(command);
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
                setup.claim_device(&root.join(format!("pwmchip{}", params.chip)))?;
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
        let ranges = params.pulses.ranges();
        ranges.validate().map_err(|e| ActorError::Params(format!("pulses.min_us/max_us: {e}")))?;
        setup.input("actuators", MotorInput::Actuators);
        setup.input("esc_pulses", MotorInput::Pulses);
        setup.input("param_set", MotorInput::Param);
        setup.timer("watchdog", timeout / 4, MotorInput::Watchdog);
        setup.timer("health_report", Duration::from_secs(1), MotorInput::Health);
        Ok(MotorActor {
            pulses: params.pulses.clone(),
            ranges,
            outputs: params.channels.len(),
            direct: DirectPulses::default(),
            armed: false,
            direct_written: false,
            param_decl: setup.output("param_decl"),
            name: setup.name().to_owned(),
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
        self.param_decl.publish(declare(
            esc_range_params(self.outputs),
            &self.ranges,
            &self.name,
            true,
            ctx.now(),
        ));
        Ok(())
    }

    async fn handle(&mut self, ctx: &Context, input: MotorInput) -> Result<(), ActorError> {
        let Some(thread) = self.thread().cloned() else {
            return Err(ActorError::Failed("motor outputs not started".into()));
        };
        match input {
            MotorInput::Actuators(outputs) => {
                self.watchdog.on_command(ctx.now(), outputs.armed);
                self.armed = outputs.armed;
                // Fresh direct pulses win while disarmed; otherwise the commands, each onto its
                // output's range.
                let command = match self.direct.pulses_us(ctx.now(), self.armed) {
                    Some(pulses_us) => {
                        self.direct_written = true;
                        PulseCommand::direct(pulses_us)
                    }
                    None => {
                        self.direct_written = false;
                        pulse_widths_us(&outputs, &self.pulses, &self.ranges)
                    }
                };
                thread.send(command);
            }
            MotorInput::Pulses(pulses) => {
                if let Err(e) = self.direct.on_message(&pulses, ctx.now()) {
                    tracing::warn!(actor = %self.name, "direct ESC pulses refused, outputs at the disarmed pulse: {e}");
                }
                if !self.armed {
                    self.write_direct_or_disarmed(&thread, ctx.now());
                }
            }
            MotorInput::Param(set) => {
                // Armed (the newest commands say so), a range change is refused here too: the
                // link refuses it first, but a bench may publish `param_set` without one.
                let outcome = apply_set(
                    esc_range_params(self.outputs),
                    &mut self.ranges,
                    &set,
                    self.armed,
                    EscRanges::validate,
                );
                if answer(&self.name, &set, outcome) {
                    self.param_decl.publish(declare(
                        esc_range_params(self.outputs),
                        &self.ranges,
                        &self.name,
                        false,
                        set.time,
                    ));
                }
            }
            MotorInput::Watchdog(now) => {
                if self.direct_written && self.direct.pulses_us(now, self.armed).is_none() {
                    self.write_direct_or_disarmed(&thread, now);
                }
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
    fn servo_ranges_apply_disarmed_only_and_direct_pulses_drive_only_disarmed_and_time_out() {
        let fake = FakePwmRoot::new("actor-esc", 0, &[0, 1, 2, 3]);
        let params = MotorActorParams { root: fake.root.clone(), ..MotorActorParams::default() };
        let mut setup = TestSetup::new("motors", "/");
        let mut actor = MotorActor::build(&params, &mut setup).expect("build");
        let ctx = setup.context();
        let clock = setup.manual_clock();
        clock.set(Time::from_micros(1_000_000));
        ready(actor.start(&ctx)).expect("start");
        let decl: Vec<ParamDecl> = setup.published("param_decl");
        let names: Vec<&str> = decl[0].params.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(names.len(), 8, "two per channel: {names:?}");
        assert_eq!(decl[0].params[1].value, 2000.0, "SERVO1_MAX starts at pulses.max_us");

        // SERVO2_MIN/MAX set: the same command maps onto output 2's own range at once.
        for (name, value) in [("SERVO2_MIN", 1080.0), ("SERVO2_MAX", 1920.0), ("SERVO2_MAX", f64::NAN)] {
            let set =
                ParamSet { time: Time::from_micros(1_000_000), name: name.into(), value, restore: false };
            ready(actor.handle(&ctx, setup.input("param_set", set))).expect("param");
        }
        let decl: Vec<ParamDecl> = setup.published("param_decl");
        assert_eq!(decl.last().expect("declared again").params[3].value, 1920.0, "NaN refused, kept");
        ready(actor.handle(&ctx, setup.input("actuators", armed(1_000_000, 0.5)))).expect("apply");
        wait_for(&fake, "pwmchip0/pwm1/duty_cycle", "1500000");
        ready(actor.handle(&ctx, setup.input("actuators", armed(1_002_500, 0.25)))).expect("apply");
        wait_for(&fake, "pwmchip0/pwm1/duty_cycle", "1290000");
        wait_for(&fake, "pwmchip0/pwm0/duty_cycle", "1250000");

        // Armed: a range change is refused (declared back unchanged) and the pulses stay.
        let set = ParamSet {
            time: Time::from_micros(1_002_500),
            name: "SERVO1_MAX".into(),
            value: 1100.0,
            restore: false,
        };
        ready(actor.handle(&ctx, setup.input("param_set", set))).expect("param");
        let decl: Vec<ParamDecl> = setup.published("param_decl");
        assert_eq!(decl.last().expect("declared again").params[1].value, 2000.0, "refused while armed");
        ready(actor.handle(&ctx, setup.input("actuators", armed(1_003_000, 0.25)))).expect("apply");
        std::thread::sleep(Duration::from_millis(20));
        assert_eq!(fake.read("pwmchip0/pwm0/duty_cycle"), "1250000", "the range in force");

        // Armed: direct pulses are ignored.
        let direct = |t_us: u64, pulse_us: f64| EscPulses {
            time: Time::from_micros(t_us),
            control: true,
            pulses_us: [pulse_us; MAX_MOTORS],
        };
        clock.set(Time::from_micros(1_005_000));
        ready(actor.handle(&ctx, setup.input("esc_pulses", direct(1_005_000, 1700.0)))).expect("pulses");
        std::thread::sleep(Duration::from_millis(20));
        assert_eq!(fake.read("pwmchip0/pwm0/duty_cycle"), "1250000", "armed: the mixer rules");

        // Disarmed: they drive the ESCs, an out-of-range one drops to the disarmed pulse, and
        // silence does after 0.1 s.
        let disarmed =
            ActuatorOutputs { time: Time::from_micros(1_010_000), armed: false, motors: [0.0; MAX_MOTORS] };
        clock.set(Time::from_micros(1_010_000));
        ready(actor.handle(&ctx, setup.input("actuators", disarmed))).expect("disarm");
        ready(actor.handle(&ctx, setup.input("esc_pulses", direct(1_010_000, 1700.0)))).expect("pulses");
        wait_for(&fake, "pwmchip0/pwm3/duty_cycle", "1700000");
        ready(actor.handle(&ctx, setup.input("esc_pulses", direct(1_010_000, 2300.0)))).expect("pulses");
        wait_for(&fake, "pwmchip0/pwm3/duty_cycle", "1000000");
        ready(actor.handle(&ctx, setup.input("esc_pulses", direct(1_010_000, 1600.0)))).expect("pulses");
        wait_for(&fake, "pwmchip0/pwm3/duty_cycle", "1600000");
        clock.set(Time::from_micros(1_100_000));
        ready(actor.handle(&ctx, setup.tick("watchdog", Time::from_micros(1_100_000)))).expect("watchdog");
        std::thread::sleep(Duration::from_millis(20));
        assert_eq!(fake.read("pwmchip0/pwm3/duty_cycle"), "1600000", "still fresh at 0.09 s");
        clock.set(Time::from_micros(1_111_000));
        ready(actor.handle(&ctx, setup.tick("watchdog", Time::from_micros(1_111_000)))).expect("watchdog");
        wait_for(&fake, "pwmchip0/pwm3/duty_cycle", "1000000");
        ctx.shutdown().cancel();
        ready(actor.stop(&ctx));
    }

    #[test]
    fn a_missing_pwm_chip_names_its_path() {
        let fake = FakePwmRoot::new("actor-missing", 0, &[]);
        let params = MotorActorParams { root: fake.root.clone(), chip: 7, ..MotorActorParams::default() };
        let err = MotorActor::build(&params, &mut TestSetup::new("motors", "/")).err().expect("no chip");
        assert!(err.to_string().contains("pwmchip7/export"), "{err}");
    }
}
