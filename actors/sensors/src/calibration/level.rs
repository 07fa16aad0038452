//! Board level: the sensor board's roll and pitch against the airframe, from the vehicle
//! standing still on level ground after accelerometer calibration (ArduPilot's
//! `AHRS_TRIM_X/Y`, PX4's `SENS_BOARD_X/Y_OFF`).

use kestrel_proto::calibration::{AccelCalibration, BoardLevel};
use kestrel_proto::messages::ImuSample;
use kestrel_proto::units::GRAVITY_M_S2;

use crate::calibration::still::{NotStill, StillLimits, StillWindow, exceeds, still_window};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelSettings {
    pub still: StillLimits,
    /// Largest tilt taken as the board's (degrees); more means the ground is not level.
    pub max_tilt_deg: f64,
    /// Largest difference of the calibrated specific force from 1 g (fraction): more means
    /// the accelerometer is not calibrated, or the vehicle is not on the ground.
    pub max_gravity_error: f64,
}

impl Default for LevelSettings {
    fn default() -> LevelSettings {
        LevelSettings { still: StillLimits::default(), max_tilt_deg: 10.0, max_gravity_error: 0.05 }
    }
}

/// A board level and how it was found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelFit {
    pub level: BoardLevel,
    /// Angle between the board's down axis and gravity (degrees).
    pub tilt_deg: f64,
    /// Mean calibrated specific force's magnitude (m/s²).
    pub gravity_m_s2: f64,
    pub window: StillWindow,
}

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LevelCalError {
    #[error("level calibration needs the vehicle at rest: {0}")]
    NotStill(#[from] NotStill),
    #[error(
        "the board is tilted {tilt_deg:.1}° from level, more than {max_deg}°: stand the vehicle on level ground"
    )]
    NotLevel { tilt_deg: f64, max_deg: f64 },
    #[error(
        "the calibrated accelerometer reads {gravity_m_s2:.3} m/s² at rest, not 1 g ({GRAVITY_M_S2}): calibrate the accelerometer first"
    )]
    NotGravity { gravity_m_s2: f64 },
    #[error("board level: {0}")]
    Invalid(#[from] kestrel_proto::calibration::InvalidCalibration),
}

/// The board's roll and pitch from `samples` of a vehicle at rest on level ground, with the
/// accelerometer calibration `accel` applied first.
pub fn calibrate_level(
    samples: &[ImuSample],
    accel: &AccelCalibration,
    settings: &LevelSettings,
) -> Result<LevelFit, LevelCalError> {
    let window = still_window(samples, &settings.still)?;
    // The calibration is affine, so the mean of the corrected samples is the corrected mean.
    let [x, y, z] = accel.apply(window.accel_mean_m_s2);
    let gravity_m_s2 = (x * x + y * y + z * z).sqrt();
    if exceeds((gravity_m_s2 / GRAVITY_M_S2 - 1.0).abs(), settings.max_gravity_error) {
        return Err(LevelCalError::NotGravity { gravity_m_s2 });
    }
    let tilt_deg = (-z / gravity_m_s2).clamp(-1.0, 1.0).acos().to_degrees();
    if tilt_deg > settings.max_tilt_deg {
        return Err(LevelCalError::NotLevel { tilt_deg, max_deg: settings.max_tilt_deg });
    }
    // At rest a board rolled φ and pitched θ reads g·(sin θ, −sin φ cos θ, −cos φ cos θ).
    let roll_deg = (-y).atan2(-z).to_degrees();
    let pitch_deg = x.atan2((y * y + z * z).sqrt()).to_degrees();
    Ok(LevelFit { level: BoardLevel::new(roll_deg, pitch_deg)?, tilt_deg, gravity_m_s2, window })
}
