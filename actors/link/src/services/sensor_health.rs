//! Driver and recorder health (`sensor_health`) as STATUSTEXT, announced as ArduCopter announces
//! a failing pre-arm check (`AP_Arming::update`): a failure that was not there before is said at
//! once, or [`NEW_FAILURE_GAP`] after the last announcement of that sensor (its
//! `report_immediately`); a failure that persists is said again every [`REPEAT_DISARMED`] while
//! disarmed (`PREARM_DISPLAY_PERIOD`, 30 s) and not while armed (ArduCopter runs its pre-arm
//! checks only on the ground), and once more as soon as the vehicle disarms with it still there.
//! A failure whose description changes (the stereo camera's `camera_blind: glare` becoming
//! `lens_capped: right`) is a new failure. A report with no error clears the sensor; nothing is
//! said for that. One text per announcement,
//! whatever the report rate (a driver's health comes once a second). Held by
//! `a_persistent_failure_is_said_at_once_then_every_30_s_on_the_ground_only`.

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::messages::SensorHealth;

/// A persisting failure is said again this often while disarmed (ArduPilot's
/// `PREARM_DISPLAY_PERIOD`).
pub const REPEAT_DISARMED: Duration = Duration::from_secs(30);
/// A new failure waits at most this long after the sensor's last announcement (ArduPilot shows a
/// pass-to-fail change once 4 s have gone since its last display).
pub const NEW_FAILURE_GAP: Duration = Duration::from_secs(4);

/// One sensor's failure, as last announced.
#[derive(Debug)]
struct Failure {
    sensor: String,
    /// The device (or fault) its latest failing report named.
    device: String,
    /// Whether its latest report carried an error.
    failing: bool,
    /// A failure (new, or found again on disarming) not yet announced.
    due: bool,
    /// When it was last announced (report time).
    said_at: Option<Time>,
}

/// Decides which health reports become a STATUSTEXT.
#[derive(Debug, Default)]
pub struct HealthAnnouncer {
    sensors: Vec<Failure>,
    armed: bool,
}

impl HealthAnnouncer {
    /// The vehicle's armed state (commander's `VehicleStatus`). Disarming makes every failure
    /// still present due again.
    pub fn set_armed(&mut self, armed: bool) {
        if self.armed && !armed {
            for f in self.sensors.iter_mut().filter(|f| f.failing) {
                f.due = true;
            }
        }
        self.armed = armed;
    }

    /// The text to send for `health`, if it is to be said now.
    pub fn on_report(&mut self, health: &SensorHealth) -> Option<String> {
        let at = match self.sensors.iter().position(|f| f.sensor == health.sensor) {
            Some(at) => at,
            None => {
                self.sensors.push(Failure {
                    sensor: health.sensor.clone(),
                    device: String::new(),
                    failing: false,
                    due: false,
                    said_at: None,
                });
                self.sensors.len() - 1
            }
        };
        let f = &mut self.sensors[at];
        if health.errors == 0 {
            f.failing = false;
            f.due = false;
            return None;
        }
        if !f.failing || f.device != health.device {
            f.failing = true;
            f.due = true;
            f.device.clone_from(&health.device);
        }
        let since = f.said_at.map(|t| health.time.saturating_since(t));
        let say = match since {
            None => true,
            Some(gap) => (f.due && gap >= NEW_FAILURE_GAP) || (!self.armed && gap >= REPEAT_DISARMED),
        };
        if !say {
            return None;
        }
        f.due = false;
        f.said_at = Some(health.time);
        Some(format!("{}: {} errors in the last second ({})", health.sensor, health.errors, health.device))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report(t_s: u64, errors: u64) -> SensorHealth {
        SensorHealth {
            time: Time::from_micros(t_s * 1_000_000),
            sensor: "recorder".into(),
            device: "flight log write failed".into(),
            rate_hz: 0.0,
            errors,
            errors_total: errors,
            clipped: 0,
        }
    }

    /// The seconds at which reports once a second from `from` to `to` (exclusive) are said.
    fn said(a: &mut HealthAnnouncer, from: u64, to: u64, errors: u64) -> Vec<u64> {
        (from..to).filter(|&t| a.on_report(&report(t, errors)).is_some()).collect()
    }

    #[test]
    fn a_persistent_failure_is_said_at_once_then_every_30_s_on_the_ground_only() {
        let mut a = HealthAnnouncer::default();
        assert_eq!(said(&mut a, 0, 5, 0), [] as [u64; 0], "a healthy sensor is quiet");
        assert_eq!(said(&mut a, 5, 70, 1), [5, 35, 65], "at once, then every 30 s while disarmed");
        a.set_armed(true);
        assert_eq!(said(&mut a, 70, 200, 1), [] as [u64; 0], "not repeated in flight");
        a.set_armed(false);
        assert_eq!(said(&mut a, 200, 240, 1), [200, 230], "said again on disarming");
        // Cleared, then failing again 2 s after the last text: said 4 s after it.
        assert_eq!(said(&mut a, 240, 241, 0), [] as [u64; 0]);
        let mut b = HealthAnnouncer::default();
        assert_eq!(said(&mut b, 0, 1, 1), [0]);
        assert_eq!(said(&mut b, 1, 2, 0), [] as [u64; 0]);
        assert_eq!(said(&mut b, 2, 8, 1), [4], "a new failure waits out the 4 s gap, no more");
        // A new failure in flight is said at once too.
        let mut c = HealthAnnouncer::default();
        c.set_armed(true);
        assert_eq!(said(&mut c, 10, 50, 1), [10]);
    }

    #[test]
    fn another_fault_of_a_failing_sensor_is_a_new_failure() {
        let mut a = HealthAnnouncer::default();
        a.set_armed(true);
        assert_eq!(said(&mut a, 0, 10, 1), [0]);
        let mut capped = report(10, 1);
        capped.device = "stereo camera: lens_capped: right".into();
        assert!(a.on_report(&capped).is_some(), "said at once: the last text is 10 s old");
    }

    #[test]
    fn each_sensor_is_announced_on_its_own() {
        let mut a = HealthAnnouncer::default();
        let mut gps = report(0, 3);
        gps.sensor = "gps".into();
        assert!(a.on_report(&report(0, 1)).is_some());
        assert_eq!(
            a.on_report(&gps).as_deref(),
            Some("gps: 3 errors in the last second (flight log write failed)")
        );
    }
}
