//! Turning a driver's running counters into one [`SensorHealth`] report per window.

use kestrel_proto::Time;
use kestrel_proto::messages::SensorHealth;

/// Running totals a driver keeps (they only grow).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    /// Messages published.
    pub published: u64,
    /// Bad input skipped.
    pub errors: u64,
    /// Clipped IMU samples.
    pub clipped: u64,
}

/// The previous report's totals and time, to turn totals into per-window figures.
#[derive(Clone, Debug)]
pub struct HealthWindow {
    sensor: String,
    device: String,
    last: Counters,
    last_time: Time,
}

impl HealthWindow {
    /// A window for driver `sensor` reading `device`, opened at `start`.
    pub fn new(sensor: &str, device: &str, start: Time) -> HealthWindow {
        HealthWindow {
            sensor: sensor.to_owned(),
            device: device.to_owned(),
            last: Counters::default(),
            last_time: start,
        }
    }

    /// The report for the window ending at `now` with running totals `totals`; starts the next
    /// window. A window of zero length reports a rate of 0.
    pub fn report(&mut self, now: Time, totals: Counters) -> SensorHealth {
        let span_s = now.saturating_since(self.last_time).as_secs_f64();
        let published = totals.published.saturating_sub(self.last.published);
        let health = SensorHealth {
            time: now,
            sensor: self.sensor.clone(),
            device: self.device.clone(),
            rate_hz: if span_s > 0.0 { published as f64 / span_s } else { 0.0 },
            errors: totals.errors.saturating_sub(self.last.errors),
            errors_total: totals.errors,
            clipped: totals.clipped.saturating_sub(self.last.clipped),
        };
        self.last = totals;
        self.last_time = now;
        health
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reports_per_window_rates_and_counts() {
        let mut window = HealthWindow::new("gps", "/dev/ttyAMA0", Time::from_micros(1_000_000));
        let first =
            window.report(Time::from_micros(2_000_000), Counters { published: 5, errors: 2, clipped: 0 });
        assert_eq!((first.rate_hz, first.errors, first.errors_total), (5.0, 2, 2));
        let second =
            window.report(Time::from_micros(2_500_000), Counters { published: 9, errors: 2, clipped: 3 });
        assert_eq!((second.rate_hz, second.errors, second.errors_total, second.clipped), (8.0, 0, 2, 3));
        assert_eq!(second.device, "/dev/ttyAMA0");
        let empty =
            window.report(Time::from_micros(2_500_000), Counters { published: 9, errors: 2, clipped: 3 });
        assert_eq!(empty.rate_hz, 0.0);
    }
}
