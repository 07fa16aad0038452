//! The motors' PWM outputs with their safety rules: every channel starts at the disarmed pulse;
//! commands drive the motors only while they say `armed`; a write that fails is counted and
//! tried again at the next pass (a command or a retry), never turned into a disarm — one EIO
//! from the RCIO co-processor must not cut a motor in the air; and dropping the output (the end
//! of the output thread, at shutdown) writes the disarmed pulse. Channels stay enabled when
//! disarmed, so ESCs keep seeing a valid "stop" signal.

use std::path::Path;
use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::messages::MAX_MOTORS;

use crate::pwm::pulses::{PulseCommand, PulseConfig};
use crate::pwm::sysfs::{PwmChannel, PwmError};

/// One PWM output: the sysfs channel, or a test's stand-in.
pub trait PwmOut: Send + 'static {
    /// Sets the pulse width (ns).
    fn set_duty_ns(&mut self, duty_ns: u64) -> std::io::Result<()>;
    /// What it writes to, for reports.
    fn path(&self) -> &Path;
}

impl PwmOut for PwmChannel {
    fn set_duty_ns(&mut self, duty_ns: u64) -> std::io::Result<()> {
        PwmChannel::set_duty_ns(self, duty_ns)
    }

    fn path(&self) -> &Path {
        self.duty_path()
    }
}

/// The motor outputs.
#[derive(Debug)]
pub struct MotorOutput<C: PwmOut = PwmChannel> {
    channels: Vec<C>,
    config: PulseConfig,
    /// The pulse each motor should have (µs).
    target_us: [u32; MAX_MOTORS],
    /// The pulse each channel last took (µs); `None` after a failed write.
    written_us: [Option<u32>; MAX_MOTORS],
    armed: bool,
    writes: u64,
    errors: u64,
    /// Since when some channel has been behind its target (failed writes, not yet retried
    /// successfully).
    failing_since: Option<Time>,
}

impl MotorOutput<PwmChannel> {
    /// Opens `channels` (motor 1, 2, ... in the frame's order; at most 8) of
    /// `<root>/pwmchip<chip>` at the disarmed pulse.
    pub fn open(
        root: &Path,
        chip: u32,
        channels: &[u32],
        config: PulseConfig,
        sleep: &mut impl FnMut(Duration),
    ) -> Result<MotorOutput, PwmError> {
        config.validate().map_err(PwmError::Config)?;
        if channels.len() > MAX_MOTORS {
            return Err(PwmError::Config(format!(
                "{} channels, at most {MAX_MOTORS} motors",
                channels.len()
            )));
        }
        let period_ns = config.period_ns();
        let disarmed_ns = u64::from(config.disarmed_us) * 1000;
        let channels = channels
            .iter()
            .map(|&ch| PwmChannel::open(root, chip, ch, period_ns, disarmed_ns, sleep))
            .collect::<Result<Vec<_>, _>>()?;
        MotorOutput::on_channels(channels, config)
    }
}

impl<C: PwmOut> MotorOutput<C> {
    /// The outputs on `channels`, which already carry the disarmed pulse.
    pub fn on_channels(channels: Vec<C>, config: PulseConfig) -> Result<MotorOutput<C>, PwmError> {
        config.validate().map_err(PwmError::Config)?;
        if channels.len() > MAX_MOTORS {
            return Err(PwmError::Config(format!(
                "{} channels, at most {MAX_MOTORS} motors",
                channels.len()
            )));
        }
        let disarmed = config.disarmed_us;
        Ok(MotorOutput {
            channels,
            config,
            target_us: [disarmed; MAX_MOTORS],
            written_us: [Some(disarmed); MAX_MOTORS],
            armed: false,
            writes: 0,
            errors: 0,
            failing_since: None,
        })
    }

    /// Whether the last command armed the motors.
    pub fn is_armed(&self) -> bool {
        self.armed
    }

    /// Takes a command at `now` and writes its pulses.
    pub fn apply(&mut self, command: &PulseCommand, now: Time) {
        self.armed = command.armed;
        self.target_us = command.pulses_us;
        self.write_all(now);
    }

    /// Writes the disarmed pulse to every motor.
    pub fn disarm(&mut self, now: Time) {
        self.armed = false;
        self.target_us = [self.config.disarmed_us; MAX_MOTORS];
        self.write_all(now);
    }

    /// Writes again what failed before, if anything did.
    pub fn retry(&mut self, now: Time) {
        if self.failing_since.is_some() {
            self.write_all(now);
        }
    }

    /// Since when some channel has been behind its pulse (`None` when none is).
    pub fn failing_since(&self) -> Option<Time> {
        self.failing_since
    }

    /// How long some channel has been behind its pulse at `now` (zero when none is).
    pub fn failing_for(&self, now: Time) -> Duration {
        self.failing_since.map_or(Duration::ZERO, |since| now.saturating_since(since))
    }

    /// Successful channel writes and failed ones since the outputs opened.
    pub fn counts(&self) -> (u64, u64) {
        (self.writes, self.errors)
    }

    /// Each channel's path, for reports.
    pub fn paths(&self) -> impl Iterator<Item = &Path> {
        self.channels.iter().map(PwmOut::path)
    }

    /// Writes every channel's target; a failure is counted and left for the next pass. The
    /// first failure of an episode is logged with the file and the error.
    fn write_all(&mut self, now: Time) {
        let mut behind = false;
        for (i, channel) in self.channels.iter_mut().enumerate() {
            let us = self.target_us[i];
            match channel.set_duty_ns(u64::from(us) * 1000) {
                Ok(()) => {
                    self.written_us[i] = Some(us);
                    self.writes += 1;
                }
                Err(e) => {
                    if self.failing_since.is_none() && !behind {
                        tracing::warn!(path = %channel.path().display(), "PWM write failed, retrying: {e}");
                    }
                    self.written_us[i] = None;
                    self.errors += 1;
                    behind = true;
                }
            }
        }
        self.failing_since = if behind { Some(self.failing_since.unwrap_or(now)) } else { None };
    }
}

impl<C: PwmOut> Drop for MotorOutput<C> {
    fn drop(&mut self) {
        self.disarm(Time::ZERO);
        if self.failing_since.is_some() {
            tracing::error!("could not write the disarmed pulse to every motor on shutdown");
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use std::path::PathBuf;
    use std::sync::{Arc, Mutex};

    use super::*;
    use crate::pwm::sysfs::tests::FakePwmRoot;

    /// A channel that records its pulses and fails while told to.
    #[derive(Clone, Debug, Default)]
    pub(crate) struct FakeChannel {
        pub(crate) pulses_ns: Arc<Mutex<Vec<u64>>>,
        pub(crate) failing: Arc<Mutex<bool>>,
        path: PathBuf,
    }

    impl FakeChannel {
        pub(crate) fn last_ns(&self) -> Option<u64> {
            self.pulses_ns.lock().unwrap().last().copied()
        }

        pub(crate) fn fail(&self, failing: bool) {
            *self.failing.lock().unwrap() = failing;
        }
    }

    impl PwmOut for FakeChannel {
        fn set_duty_ns(&mut self, duty_ns: u64) -> std::io::Result<()> {
            if *self.failing.lock().unwrap() {
                return Err(std::io::Error::from_raw_os_error(5)); // EIO
            }
            self.pulses_ns.lock().unwrap().push(duty_ns);
            Ok(())
        }

        fn path(&self) -> &Path {
            &self.path
        }
    }

    fn duty(fake: &FakePwmRoot, channel: u32) -> String {
        fake.read(&format!("pwmchip0/pwm{channel}/duty_cycle"))
    }

    fn command(armed: bool, level: f64) -> PulseCommand {
        let outputs =
            kestrel_proto::messages::ActuatorOutputs { time: Time::ZERO, armed, motors: [level; MAX_MOTORS] };
        let config = PulseConfig::default();
        crate::pwm::pulse_widths_us(&outputs, &config, &config.ranges())
    }

    #[test]
    fn disarmed_until_armed_and_disarmed_on_drop() {
        let fake = FakePwmRoot::new("motors", 0, &[0, 1, 2, 3]);
        let mut motors = MotorOutput::open(&fake.root, 0, &[0, 1, 2, 3], PulseConfig::default(), &mut |_| {})
            .expect("open");
        assert_eq!(duty(&fake, 2), "1000000");
        motors.apply(&command(false, 0.8), Time::from_micros(1_000));
        assert_eq!(duty(&fake, 2), "1000000");
        motors.apply(&command(true, 0.5), Time::from_micros(2_000));
        assert!(motors.is_armed());
        assert_eq!(duty(&fake, 0), "1500000");
        assert_eq!(duty(&fake, 3), "1500000");
        assert_eq!(motors.counts(), (8, 0), "two commands to four channels");
        drop(motors);
        assert_eq!(duty(&fake, 0), "1000000");
        assert_eq!(fake.read("pwmchip0/pwm0/enable"), "1");
    }

    #[test]
    fn a_failing_write_is_counted_and_retried_never_turned_into_a_disarm() {
        let channels: Vec<FakeChannel> = (0..4).map(|_| FakeChannel::default()).collect();
        let mut motors = MotorOutput::on_channels(channels.clone(), PulseConfig::default()).expect("outputs");
        let t = Time::from_micros;
        motors.apply(&command(true, 0.6), t(1_000_000));
        channels[2].fail(true);
        motors.apply(&command(true, 0.7), t(1_002_500));
        assert_eq!(channels[2].last_ns(), Some(1_600_000), "the failed channel kept its last pulse");
        assert_eq!(channels[1].last_ns(), Some(1_700_000), "the others took the new one");
        motors.retry(t(1_005_000));
        assert_eq!(motors.failing_for(t(1_050_000)), Duration::from_micros(47_500));
        assert_eq!(motors.counts().1, 2);
        channels[2].fail(false);
        motors.retry(t(1_052_500));
        assert_eq!(channels[2].last_ns(), Some(1_700_000), "retried without a new command");
        assert_eq!(motors.failing_for(t(1_060_000)), Duration::ZERO);
        assert!(motors.is_armed());
        assert!(
            channels.iter().all(|c| !c.pulses_ns.lock().unwrap().contains(&1_000_000)),
            "no disarmed pulse was written in flight"
        );
    }

    #[test]
    fn too_many_channels_or_bad_pulses_are_config_errors() {
        let fake = FakePwmRoot::new("config", 0, &[]);
        let nine: Vec<u32> = (0..9).collect();
        let err = MotorOutput::open(&fake.root, 0, &nine, PulseConfig::default(), &mut |_| {});
        assert!(matches!(err, Err(PwmError::Config(_))));
        let bad = PulseConfig { min_us: 2500, ..PulseConfig::default() };
        let err = MotorOutput::open(&fake.root, 0, &[0], bad, &mut |_| {});
        assert!(matches!(err, Err(PwmError::Config(_))));
    }
}
