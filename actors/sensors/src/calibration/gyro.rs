//! Gyro offset at rest: the mean rate over a still window, refused when the gyro or the
//! accelerometer says the vehicle moved, or when the "offset" is a steady turn.

use kestrel_proto::calibration::GyroCalibration;
use kestrel_proto::messages::ImuSample;

use crate::calibration::still::{AXES, NotStill, StillLimits, StillWindow, still_window};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GyroSettings {
    pub still: StillLimits,
    /// Largest offset taken as the sensor's own (rad/s): the MPU-9250's zero-rate output is
    /// within ±5 °/s (0.09 rad/s) at 25 °C; beyond this the vehicle is turning steadily.
    pub max_offset_rad_s: f64,
}

impl Default for GyroSettings {
    fn default() -> GyroSettings {
        GyroSettings { still: StillLimits::default(), max_offset_rad_s: 0.15 }
    }
}

/// A gyro calibration and how good it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GyroFit {
    pub calibration: GyroCalibration,
    /// 1σ uncertainty of each offset (rad/s): the spread over √samples.
    pub offset_std_error_rad_s: [f64; 3],
    pub window: StillWindow,
}

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum GyroCalError {
    #[error("gyro calibration needs the vehicle at rest: {0}")]
    NotStill(#[from] NotStill),
    #[error(
        "gyro {axis} axis reads {offset_rad_s:.4} rad/s at rest, more than {max_rad_s} rad/s: the vehicle is turning or the gyro is faulty"
    )]
    OffsetTooLarge { axis: &'static str, offset_rad_s: f64, max_rad_s: f64 },
}

/// The gyro offset of `samples` taken at rest.
pub fn calibrate_gyro(samples: &[ImuSample], settings: &GyroSettings) -> Result<GyroFit, GyroCalError> {
    let window = still_window(samples, &settings.still)?;
    let offset = window.gyro_mean_rad_s;
    if let Some(axis) = (0..3).find(|&i| offset[i].abs() > settings.max_offset_rad_s) {
        return Err(GyroCalError::OffsetTooLarge {
            axis: AXES[axis],
            offset_rad_s: offset[axis],
            max_rad_s: settings.max_offset_rad_s,
        });
    }
    let root_n = (window.samples as f64).sqrt();
    Ok(GyroFit {
        calibration: GyroCalibration { gyro_offset_rad_s: offset },
        offset_std_error_rad_s: window.gyro_std_rad_s.map(|s| s / root_n),
        window,
    })
}
