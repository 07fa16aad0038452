//! A controller gone quiet while the motors are armed: reported once per silence. The pulses
//! are held, never cut: a command late because the host was busy is no reason to drop a flying
//! vehicle, and PX4's and ArduPilot's outputs keep their last values too; the commands' own
//! `armed` flag and shutdown are what disarm.

use std::time::Duration;

use kestrel_proto::Time;

/// When the last command came and whether it armed.
#[derive(Clone, Debug)]
pub struct CommandWatchdog {
    timeout: Duration,
    last_command: Option<Time>,
    armed: bool,
    silent: bool,
    silences: u64,
}

impl CommandWatchdog {
    /// A watchdog for silences longer than `timeout`.
    pub fn new(timeout: Duration) -> CommandWatchdog {
        CommandWatchdog { timeout, last_command: None, armed: false, silent: false, silences: 0 }
    }

    /// A command arrived at `now`.
    pub fn on_command(&mut self, now: Time, armed: bool) {
        self.last_command = Some(now);
        self.armed = armed;
        self.silent = false;
    }

    /// Whether a silence began at `now` (armed, no command within the timeout): once per silence.
    pub fn check(&mut self, now: Time) -> bool {
        let stale = self.last_command.is_none_or(|t| now - t > self.timeout);
        let began = self.armed && stale && !self.silent;
        self.silent = self.armed && stale;
        if began {
            self.silences += 1;
        }
        began
    }

    /// Whether the last command armed the motors.
    pub fn armed(&self) -> bool {
        self.armed
    }

    /// Silences seen while armed.
    pub fn silences(&self) -> u64 {
        self.silences
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_silent_controller_is_reported_once_per_silence_while_armed() {
        let t = Time::from_micros;
        let mut w = CommandWatchdog::new(Duration::from_millis(100));
        w.on_command(t(1_000_000), true);
        assert!(!w.check(t(1_090_000)));
        assert!(w.check(t(1_101_000)), "the silence begins");
        assert!(!w.check(t(1_200_000)), "reported once");
        w.on_command(t(1_300_000), true);
        assert!(w.check(t(1_401_000)), "a second silence");
        assert_eq!(w.silences(), 2);
        w.on_command(t(1_500_000), false);
        assert!(!w.check(t(2_000_000)), "disarmed: nothing to hold");
        assert!(!w.armed());
    }
}
