//! Whether a window of IMU samples was taken at rest, and its means: the gate that the
//! rest-based calibrations (accelerometer, gyro, board level) stand behind.

use kestrel_proto::messages::ImuSample;

/// Body axis names, for errors a person reads.
pub const AXES: [&str; 3] = ["forward", "right", "down"];

/// How still and how long a window must be.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StillLimits {
    /// Fewest samples (at 400 Hz, 200 is half a second).
    pub min_samples: usize,
    /// Shortest span from first to last stamp (s), so a burst of samples is not taken for rest.
    pub min_duration_s: f64,
    /// Largest 1σ spread of any accelerometer axis (m/s²); the MPU-9250 on a bench shows
    /// ~0.05, a hand holding the vehicle ~0.3.
    pub max_accel_std_m_s2: f64,
    /// Largest 1σ spread of any gyro axis (rad/s); bench noise is ~0.003.
    pub max_gyro_std_rad_s: f64,
}

impl Default for StillLimits {
    fn default() -> StillLimits {
        StillLimits {
            min_samples: 200,
            min_duration_s: 0.5,
            max_accel_std_m_s2: 0.2,
            max_gyro_std_rad_s: 0.02,
        }
    }
}

/// Means and spreads of a window at rest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StillWindow {
    pub samples: usize,
    /// First to last stamp (s).
    pub duration_s: f64,
    pub accel_mean_m_s2: [f64; 3],
    /// 1σ per axis (m/s²).
    pub accel_std_m_s2: [f64; 3],
    pub gyro_mean_rad_s: [f64; 3],
    /// 1σ per axis (rad/s).
    pub gyro_std_rad_s: [f64; 3],
}

/// Why a window is not a vehicle at rest.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NotStill {
    #[error("{got} samples, at least {need} needed: hold still longer")]
    TooFewSamples { got: usize, need: usize },
    #[error("the samples span {duration_s:.2} s, at least {need_s} s needed: hold still longer")]
    TooShort { duration_s: f64, need_s: f64 },
    #[error("sample {index} is not finite (accel {accel_m_s2:?}, gyro {gyro_rad_s:?})")]
    NonFinite { index: usize, accel_m_s2: [f64; 3], gyro_rad_s: [f64; 3] },
    #[error("stamps go backwards at sample {index}")]
    OutOfOrder { index: usize },
    #[error(
        "the vehicle moved: the {sensor} {axis} axis varied by {std:.4} {unit} (1σ), at most {max} allowed"
    )]
    Moving { sensor: &'static str, axis: &'static str, std: f64, max: f64, unit: &'static str },
}

/// Whether `value` is beyond the limit `max`; NaN is beyond every limit.
pub fn exceeds(value: f64, max: f64) -> bool {
    value.is_nan() || value > max
}

/// Mean and 1σ (sample standard deviation) per axis.
pub fn mean_std(values: impl Iterator<Item = [f64; 3]> + Clone) -> ([f64; 3], [f64; 3]) {
    let n = values.clone().count().max(1) as f64;
    let mut sum = [0.0; 3];
    for v in values.clone() {
        (0..3).for_each(|i| sum[i] += v[i]);
    }
    let mean = sum.map(|s| s / n);
    let mut var = [0.0; 3];
    for v in values {
        (0..3).for_each(|i| var[i] += (v[i] - mean[i]).powi(2));
    }
    let dof = (n - 1.0).max(1.0);
    (mean, var.map(|s| (s / dof).sqrt()))
}

/// Checks `samples` against `limits`; their means and spreads when they are a vehicle at rest.
pub fn still_window(samples: &[ImuSample], limits: &StillLimits) -> Result<StillWindow, NotStill> {
    if samples.len() < limits.min_samples.max(2) {
        return Err(NotStill::TooFewSamples { got: samples.len(), need: limits.min_samples.max(2) });
    }
    for (index, s) in samples.iter().enumerate() {
        if !s.accel_m_s2.iter().chain(&s.gyro_rad_s).all(|v| v.is_finite()) {
            return Err(NotStill::NonFinite { index, accel_m_s2: s.accel_m_s2, gyro_rad_s: s.gyro_rad_s });
        }
        if index > 0 && s.time < samples[index - 1].time {
            return Err(NotStill::OutOfOrder { index });
        }
    }
    let (first, last) = (samples[0].time, samples[samples.len() - 1].time);
    let duration_s = last.saturating_since(first).as_secs_f64();
    if duration_s < limits.min_duration_s {
        return Err(NotStill::TooShort { duration_s, need_s: limits.min_duration_s });
    }
    let (accel_mean_m_s2, accel_std_m_s2) = mean_std(samples.iter().map(|s| s.accel_m_s2));
    let (gyro_mean_rad_s, gyro_std_rad_s) = mean_std(samples.iter().map(|s| s.gyro_rad_s));
    let checks = [
        ("accelerometer", accel_std_m_s2, limits.max_accel_std_m_s2, "m/s²"),
        ("gyro", gyro_std_rad_s, limits.max_gyro_std_rad_s, "rad/s"),
    ];
    for (sensor, std, max, unit) in checks {
        if let Some(axis) = (0..3).find(|&i| exceeds(std[i], max)) {
            return Err(NotStill::Moving { sensor, axis: AXES[axis], std: std[axis], max, unit });
        }
    }
    Ok(StillWindow {
        samples: samples.len(),
        duration_s,
        accel_mean_m_s2,
        accel_std_m_s2,
        gyro_mean_rad_s,
        gyro_std_rad_s,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use kestrel_proto::Time;

    fn sample(i: u64, accel: [f64; 3]) -> ImuSample {
        ImuSample {
            time: Time::from_micros(i * 2500),
            gyro_rad_s: [0.0; 3],
            accel_m_s2: accel,
            dt_s: 0.0025,
            gyro_clipped: [false; 3],
            accel_clipped: [false; 3],
        }
    }

    #[test]
    fn a_shaken_window_names_the_axis_and_a_still_one_gives_its_mean() {
        let still: Vec<_> = (0..400).map(|i| sample(i, [0.0, 0.0, -9.8])).collect();
        let w = still_window(&still, &StillLimits::default()).expect("still");
        assert_eq!((w.accel_mean_m_s2[0], w.accel_std_m_s2[0], w.samples), (0.0, 0.0, 400));
        assert!((w.accel_mean_m_s2[2] + 9.8).abs() < 1e-12 && w.accel_std_m_s2[2] < 1e-12, "{w:?}");
        assert!((w.duration_s - 399.0 * 0.0025).abs() < 1e-9);
        let shaken: Vec<_> = (0..400).map(|i| sample(i, [0.0, (i as f64).sin(), -9.8])).collect();
        let err = still_window(&shaken, &StillLimits::default()).unwrap_err();
        assert!(matches!(err, NotStill::Moving { sensor: "accelerometer", axis: "right", .. }), "{err}");
        assert!(matches!(
            still_window(&still[..100], &StillLimits::default()),
            Err(NotStill::TooFewSamples { got: 100, need: 200 })
        ));
    }
}
