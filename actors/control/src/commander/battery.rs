//! The battery as the commander judges it: the newest report (for the pre-arm check) and the
//! pack voltage held under `battery_low_volt` / `battery_critical_volt` for
//! `battery_volt_timer_s` (ArduPilot's `BATT_LOW_VOLT`, `BATT_CRT_VOLT`, `BATT_LOW_TIMER`),
//! which fire the low and critical failsafes as the share remaining does.

use kestrel_proto::Time;
use kestrel_proto::messages::BatteryStatus;

use super::failsafe::HeldFor;
use super::params::FailsafeParams;

/// The newest battery report and how long the voltage has been under each threshold.
#[derive(Debug, Default)]
pub(crate) struct Battery {
    report: Option<BatteryStatus>,
    /// The pack voltage under `battery_low_volt`, and since when.
    low_volt: HeldFor,
    /// The pack voltage under `battery_critical_volt`, and since when.
    critical_volt: HeldFor,
}

/// Which battery failsafes hold now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct BatteryFailsafes {
    pub low: bool,
    pub critical: bool,
}

impl Battery {
    pub fn on_report(&mut self, battery: &BatteryStatus) {
        self.report = Some(battery.clone());
    }

    /// The newest report, however old.
    pub fn report(&self) -> Option<&BatteryStatus> {
        self.report.as_ref()
    }

    /// The low and critical failsafes at `now`: armed, and the share remaining under its
    /// threshold or the voltage under its (a threshold of 0 V is off) for the timer. The
    /// voltage timers run only while armed.
    pub fn failsafes(&mut self, now: Time, armed: bool, fs: &FailsafeParams) -> BatteryFailsafes {
        let remaining = self.report.as_ref().map(|b| b.remaining);
        let volts = self.report.as_ref().map(|b| b.voltage_v);
        let under = |threshold: f64| threshold > 0.0 && volts.is_some_and(|v| v < threshold);
        let timer = fs.battery_volt_timer_s;
        let low_volt = self.low_volt.check(now, armed && under(fs.battery_low_volt), timer);
        let critical_volt = self.critical_volt.check(now, armed && under(fs.battery_critical_volt), timer);
        BatteryFailsafes {
            low: armed && (remaining.is_some_and(|r| r < fs.battery_low) || low_volt),
            critical: armed && (remaining.is_some_and(|r| r < fs.battery_critical) || critical_volt),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report(t_s: f64, voltage_v: f64, remaining: f64) -> BatteryStatus {
        BatteryStatus {
            time: Time::from_secs_f64(t_s),
            voltage_v,
            current_a: 10.0,
            consumed_mah: 0.0,
            remaining,
        }
    }

    fn volts(low: f64, critical: f64) -> FailsafeParams {
        FailsafeParams { battery_low_volt: low, battery_critical_volt: critical, ..FailsafeParams::default() }
    }

    const NONE: BatteryFailsafes = BatteryFailsafes { low: false, critical: false };

    #[test]
    fn the_share_remaining_fires_at_once_while_armed_only() {
        let (mut b, fs) = (Battery::default(), FailsafeParams::default());
        let t = Time::from_secs_f64(1.0);
        assert_eq!(b.failsafes(t, true, &fs), NONE, "no report, nothing judged");
        b.on_report(&report(1.0, 15.0, 0.2));
        assert_eq!(b.failsafes(t, true, &fs), BatteryFailsafes { low: true, critical: false });
        b.on_report(&report(1.0, 15.0, 0.05));
        assert_eq!(b.failsafes(t, true, &fs), BatteryFailsafes { low: true, critical: true });
        assert_eq!(b.failsafes(t, false, &fs), NONE, "disarmed");
    }

    #[test]
    fn a_voltage_under_its_threshold_fires_once_held_for_the_timer_and_a_recovery_restarts_it() {
        let (mut b, fs) = (Battery::default(), volts(14.0, 13.0));
        let t = Time::from_secs_f64;
        b.on_report(&report(0.0, 13.5, 1.0));
        assert_eq!(b.failsafes(t(0.0), true, &fs), NONE);
        assert_eq!(b.failsafes(t(9.9), true, &fs), NONE);
        assert_eq!(b.failsafes(t(10.0), true, &fs), BatteryFailsafes { low: true, critical: false });
        b.on_report(&report(10.5, 14.5, 1.0));
        assert_eq!(b.failsafes(t(10.5), true, &fs), NONE, "recovered");
        b.on_report(&report(11.0, 12.0, 1.0));
        assert_eq!(b.failsafes(t(11.0), true, &fs), NONE, "the timer starts over");
        assert_eq!(b.failsafes(t(21.0), true, &fs), BatteryFailsafes { low: true, critical: true });
    }

    #[test]
    fn a_threshold_of_zero_volts_is_off() {
        let (mut b, fs) = (Battery::default(), volts(0.0, 0.0));
        b.on_report(&report(0.0, 1.0, 1.0));
        assert_eq!(b.failsafes(Time::from_secs_f64(0.0), true, &fs), NONE);
        assert_eq!(b.failsafes(Time::from_secs_f64(100.0), true, &fs), NONE);
    }
}
