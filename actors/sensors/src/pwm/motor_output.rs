//! The motors' PWM outputs with their safety rules: every channel starts at the disarmed
//! pulse; commands drive the motors only while they say `armed`; if commands stop for longer
//! than the timeout (controller stopped, or the host too busy to deliver them) the last pulses
//! are held and the silence is reported, never cut in the air; and
//! dropping the output (shutdown, actor restart) writes the disarmed pulse. Channels stay
//! enabled when disarmed, so ESCs keep seeing a valid "stop" signal.

use std::path::Path;
use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::messages::{ActuatorOutputs, MAX_MOTORS};

use crate::pwm::pulses::{PulseConfig, pulse_widths_us};
use crate::pwm::sysfs::{PwmChannel, PwmError};

/// The motor outputs.
#[derive(Debug)]
pub struct MotorOutput {
    channels: Vec<PwmChannel>,
    config: PulseConfig,
    /// Longest silence from the controller before the motors are disarmed.
    timeout: Duration,
    /// When the last command arrived; `None` before the first.
    last_command: Option<Time>,
    armed: bool,
    /// In a silence of the controller, and how many there were.
    silent: bool,
    silences: u64,
}

impl MotorOutput {
    /// Opens `channels` (motor 1, 2, ... in the frame's order; at most 8) of
    /// `<root>/pwmchip<chip>` at the disarmed pulse.
    pub fn open(
        root: &Path,
        chip: u32,
        channels: &[u32],
        config: PulseConfig,
        timeout: Duration,
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
        Ok(MotorOutput {
            channels,
            config,
            timeout,
            last_command: None,
            armed: false,
            silent: false,
            silences: 0,
        })
    }

    /// Whether the last command armed the motors and is still fresh.
    pub fn is_armed(&self) -> bool {
        self.armed
    }

    /// Applies a command that arrived at `now`.
    pub fn apply(&mut self, outputs: &ActuatorOutputs, now: Time) -> Result<(), PwmError> {
        self.last_command = Some(now);
        self.silent = false;
        self.armed = outputs.armed;
        self.write(&pulse_widths_us(outputs, &self.config))
    }

    /// Notes a silence from the controller: armed, with no command within the timeout before
    /// `now`. Returns whether a silence began (once per silence). The pulses are held, never
    /// cut: a command late because the host was busy is no reason to drop a flying vehicle,
    /// and PX4's and ArduPilot's outputs keep their last values too; the commands' own
    /// `armed` flag and shutdown are what disarm.
    pub fn watchdog(&mut self, now: Time) -> bool {
        let stale = self.last_command.is_none_or(|t| now - t > self.timeout);
        let began = self.armed && stale && !self.silent;
        self.silent = self.armed && stale;
        if began {
            self.silences += 1;
        }
        began
    }

    /// Silences of the controller seen while armed.
    pub fn silences(&self) -> u64 {
        self.silences
    }

    /// Writes the disarmed pulse to every motor.
    pub fn disarm(&mut self) -> Result<(), PwmError> {
        self.armed = false;
        self.write(&[self.config.disarmed_us; MAX_MOTORS])
    }

    fn write(&self, pulses_us: &[u32; MAX_MOTORS]) -> Result<(), PwmError> {
        for (channel, &us) in self.channels.iter().zip(pulses_us) {
            channel.set_duty_ns(u64::from(us) * 1000)?;
        }
        Ok(())
    }
}

impl Drop for MotorOutput {
    fn drop(&mut self) {
        if let Err(e) = self.disarm() {
            tracing::error!("could not disarm the motors on shutdown: {e}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pwm::sysfs::tests::FakePwmRoot;

    fn duty(fake: &FakePwmRoot, channel: u32) -> String {
        fake.read(&format!("pwmchip0/pwm{channel}/duty_cycle"))
    }

    fn open(fake: &FakePwmRoot) -> MotorOutput {
        let config = PulseConfig::default();
        MotorOutput::open(&fake.root, 0, &[0, 1, 2, 3], config, Duration::from_millis(100), &mut |_| {})
            .expect("open")
    }

    fn command(armed: bool, level: f64) -> ActuatorOutputs {
        ActuatorOutputs { time: Time::ZERO, armed, motors: [level; MAX_MOTORS] }
    }

    #[test]
    fn disarmed_until_armed_and_disarmed_on_drop() {
        let fake = FakePwmRoot::new("motors", 0, &[0, 1, 2, 3]);
        let mut motors = open(&fake);
        assert_eq!(duty(&fake, 2), "1000000");
        motors.apply(&command(false, 0.8), Time::from_micros(1_000)).expect("write");
        assert_eq!(duty(&fake, 2), "1000000");
        motors.apply(&command(true, 0.5), Time::from_micros(2_000)).expect("write");
        assert!(motors.is_armed());
        assert_eq!(duty(&fake, 0), "1500000");
        assert_eq!(duty(&fake, 3), "1500000");
        drop(motors);
        assert_eq!(duty(&fake, 0), "1000000");
        assert_eq!(fake.read("pwmchip0/pwm0/enable"), "1");
    }

    #[test]
    fn a_silent_controller_is_reported_and_the_motors_hold() {
        let fake = FakePwmRoot::new("watchdog", 0, &[0, 1, 2, 3]);
        let mut motors = open(&fake);
        motors.apply(&command(true, 0.7), Time::from_micros(1_000_000)).expect("write");
        assert!(!motors.watchdog(Time::from_micros(1_090_000)));
        assert!(motors.watchdog(Time::from_micros(1_101_000)), "the silence begins");
        assert!(!motors.watchdog(Time::from_micros(1_200_000)), "reported once");
        assert_eq!(duty(&fake, 1), "1700000");
        assert!(motors.is_armed());
        motors.apply(&command(true, 0.6), Time::from_micros(1_300_000)).expect("write");
        assert!(motors.watchdog(Time::from_micros(1_401_000)), "a second silence");
        assert_eq!(motors.silences(), 2);
        motors.apply(&command(false, 0.6), Time::from_micros(1_500_000)).expect("write");
        assert!(!motors.watchdog(Time::from_micros(2_000_000)), "disarmed: nothing to hold");
        assert_eq!(duty(&fake, 1), "1000000");
    }

    #[test]
    fn too_many_channels_or_bad_pulses_are_config_errors() {
        let fake = FakePwmRoot::new("config", 0, &[]);
        let nine: Vec<u32> = (0..9).collect();
        let err =
            MotorOutput::open(&fake.root, 0, &nine, PulseConfig::default(), Duration::ZERO, &mut |_| {});
        assert!(matches!(err, Err(PwmError::Config(_))));
        let bad = PulseConfig { min_us: 2500, ..PulseConfig::default() };
        let err = MotorOutput::open(&fake.root, 0, &[0], bad, Duration::ZERO, &mut |_| {});
        assert!(matches!(err, Err(PwmError::Config(_))));
    }
}
