//! Averaging the IMU's 1 kHz samples down to the estimator's 400 Hz.
//!
//! Output instants are a fixed grid (every 2.5 ms from the first sample); each output
//! averages the samples since the previous one — two or three at 1 kHz, so the intervals
//! alternate 3 ms / 2 ms and average exactly 2.5 ms. An output is stamped with its last
//! sample's time and carries the measured interval as `dt_s`, so the estimator integrates
//! what was actually measured. Averaging (a boxcar) also stops the 1 kHz content above
//! 200 Hz from aliasing as hard as plain dropping would. Any clipped input sample marks the
//! output clipped on that axis (`ImuSample::gyro_clipped`, `accel_clipped`): an average that
//! took in a saturated reading understates the motion, however few such readings there were.

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::messages::ImuSample;
use kestrel_proto::time::duration_micros;

use crate::mpu9250::ImuReading;

/// A 400 Hz sample, clipping flags included.
#[derive(Clone, Debug, PartialEq)]
pub struct DecimatedImu {
    pub sample: ImuSample,
    /// How many input samples were averaged.
    pub samples: u32,
}

/// The averager.
#[derive(Clone, Debug)]
pub struct ImuDecimator {
    period_us: u64,
    /// Time of the last output (or of the first sample), where the next interval starts.
    last_out: Option<Time>,
    /// Next grid instant at which to output (µs).
    next_out_us: u64,
    gyro_sum: [f64; 3],
    accel_sum: [f64; 3],
    gyro_clipped: [bool; 3],
    accel_clipped: [bool; 3],
    count: u32,
    /// Input samples dropped because their time went backwards.
    pub out_of_order: u64,
}

impl ImuDecimator {
    /// An averager with outputs every `period` (2.5 ms for 400 Hz); at least 1 µs.
    pub fn new(period: Duration) -> ImuDecimator {
        ImuDecimator {
            period_us: duration_micros(period).max(1),
            last_out: None,
            next_out_us: 0,
            gyro_sum: [0.0; 3],
            accel_sum: [0.0; 3],
            gyro_clipped: [false; 3],
            accel_clipped: [false; 3],
            count: 0,
            out_of_order: 0,
        }
    }

    /// Takes one input sample; returns an output when it closes an interval. The first sample
    /// only marks where the first interval starts.
    pub fn push(&mut self, reading: &ImuReading) -> Option<DecimatedImu> {
        let t = reading.time;
        let Some(last_out) = self.last_out else {
            self.last_out = Some(t);
            self.next_out_us = t.as_micros() + self.period_us;
            return None;
        };
        if t <= last_out {
            self.out_of_order += 1;
            return None;
        }
        for i in 0..3 {
            self.gyro_sum[i] += reading.gyro_frd_rad_s[i];
            self.accel_sum[i] += reading.accel_frd_m_s2[i];
            self.gyro_clipped[i] |= reading.gyro_clipped[i];
            self.accel_clipped[i] |= reading.accel_clipped[i];
        }
        self.count += 1;
        if t.as_micros() < self.next_out_us {
            return None;
        }
        while self.next_out_us <= t.as_micros() {
            self.next_out_us += self.period_us;
        }
        let n = f64::from(self.count);
        let out = DecimatedImu {
            sample: ImuSample {
                time: t,
                gyro_rad_s: self.gyro_sum.map(|s| s / n),
                accel_m_s2: self.accel_sum.map(|s| s / n),
                dt_s: (t - last_out).as_secs_f64(),
                gyro_clipped: self.gyro_clipped,
                accel_clipped: self.accel_clipped,
            },
            samples: self.count,
        };
        self.last_out = Some(t);
        self.gyro_sum = [0.0; 3];
        self.accel_sum = [0.0; 3];
        self.gyro_clipped = [false; 3];
        self.accel_clipped = [false; 3];
        self.count = 0;
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reading(t_us: u64, gyro_x: f64, clipped: bool) -> ImuReading {
        ImuReading {
            time: Time::from_micros(t_us),
            gyro_frd_rad_s: [gyro_x, 0.0, 0.0],
            accel_frd_m_s2: [0.0, 0.0, -9.8],
            temperature_c: 30.0,
            gyro_clipped: [clipped, false, false],
            accel_clipped: [false; 3],
            mag_frd_gauss: None,
        }
    }

    #[test]
    fn one_khz_becomes_400_hz_with_measured_dt() {
        let mut decimator = ImuDecimator::new(Duration::from_micros(2500));
        let outputs: Vec<DecimatedImu> = (0..=1000u64)
            .filter_map(|k| decimator.push(&reading(10_000 + k * 1000, k as f64, false)))
            .collect();
        assert_eq!(outputs.len(), 400);
        let total_dt: f64 = outputs.iter().map(|o| o.sample.dt_s).sum();
        assert!((total_dt - 1.0).abs() < 1e-9);
        assert_eq!(outputs[0].samples, 3);
        assert_eq!(outputs[0].sample.time, Time::from_micros(13_000));
        assert!((outputs[0].sample.dt_s - 0.003).abs() < 1e-12);
        assert_eq!(outputs[0].sample.gyro_rad_s[0], 2.0); // mean of 1, 2, 3
        assert_eq!(outputs[1].samples, 2);
        assert!((outputs[1].sample.dt_s - 0.002).abs() < 1e-12);
        assert_eq!(outputs[0].sample.accel_m_s2, [0.0, 0.0, -9.8]);
    }

    #[test]
    fn clipping_is_carried_and_cleared() {
        let mut decimator = ImuDecimator::new(Duration::from_micros(2500));
        decimator.push(&reading(0, 0.0, false));
        decimator.push(&reading(1000, 0.0, true));
        decimator.push(&reading(2000, 0.0, false));
        let first = decimator.push(&reading(3000, 0.0, false)).expect("output");
        assert_eq!(first.sample.gyro_clipped, [true, false, false]);
        assert_eq!(first.sample.accel_clipped, [false; 3]);
        decimator.push(&reading(4000, 0.0, false));
        let second = decimator.push(&reading(5000, 0.0, false)).expect("output");
        assert!(!second.sample.is_clipped());
    }

    #[test]
    fn samples_going_back_in_time_are_dropped_and_counted() {
        let mut decimator = ImuDecimator::new(Duration::from_micros(2500));
        decimator.push(&reading(5000, 0.0, false));
        assert_eq!(decimator.push(&reading(4000, 0.0, false)), None);
        assert_eq!(decimator.out_of_order, 1);
    }
}
