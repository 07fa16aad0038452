//! Six-orientation accelerometer calibration: still windows with the vehicle level, on each
//! side, nose down, nose up and upside down (ArduPilot's ACCELCAL_VEHICLE_POS order) give
//! six mean readings of a known ±1 g; an affine least-squares fit `mean = T · expected + offset`
//! over the six yields the offsets and, as the length of each row of T, the per-axis scale
//! (exact for `measured = scale ⊙ (R_boardᵀ · true) + offset`, whatever the board's tilt).

use kestrel_proto::calibration::{AccelCalibration, InvalidCalibration};
use kestrel_proto::messages::ImuSample;
use kestrel_proto::units::GRAVITY_M_S2;
use nalgebra::{Matrix3, Rotation3, Vector3};

use crate::calibration::still::{AXES, NotStill, StillLimits, StillWindow, exceeds, still_window};

/// How the vehicle is set down, numbered as MAVLink's `ACCELCAL_VEHICLE_POS` (1..=6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum VehicleOrientation {
    Level,
    LeftSideDown,
    RightSideDown,
    NoseDown,
    NoseUp,
    UpsideDown,
}

impl VehicleOrientation {
    /// All six, in the order a ground station asks for them.
    pub const ALL: [VehicleOrientation; 6] = [
        VehicleOrientation::Level,
        VehicleOrientation::LeftSideDown,
        VehicleOrientation::RightSideDown,
        VehicleOrientation::NoseDown,
        VehicleOrientation::NoseUp,
        VehicleOrientation::UpsideDown,
    ];

    /// The `ACCELCAL_VEHICLE_POS` value (1..=6).
    pub fn accelcal_vehicle_pos(self) -> u32 {
        self as u32 + 1
    }

    /// The orientation of an `ACCELCAL_VEHICLE_POS` value.
    pub fn from_accelcal_vehicle_pos(pos: u32) -> Option<VehicleOrientation> {
        VehicleOrientation::ALL.get(pos.checked_sub(1)? as usize).copied()
    }

    /// What a perfect accelerometer reads at rest in this orientation, airframe FRD (m/s²):
    /// the specific force, 1 g up.
    pub fn expected_m_s2(self) -> [f64; 3] {
        let g = GRAVITY_M_S2;
        match self {
            VehicleOrientation::Level => [0.0, 0.0, -g],
            VehicleOrientation::LeftSideDown => [0.0, g, 0.0],
            VehicleOrientation::RightSideDown => [0.0, -g, 0.0],
            VehicleOrientation::NoseDown => [-g, 0.0, 0.0],
            VehicleOrientation::NoseUp => [g, 0.0, 0.0],
            VehicleOrientation::UpsideDown => [0.0, 0.0, g],
        }
    }

    /// A person's name for it.
    pub fn name(self) -> &'static str {
        match self {
            VehicleOrientation::Level => "level",
            VehicleOrientation::LeftSideDown => "on its left side",
            VehicleOrientation::RightSideDown => "on its right side",
            VehicleOrientation::NoseDown => "nose down",
            VehicleOrientation::NoseUp => "nose up",
            VehicleOrientation::UpsideDown => "upside down",
        }
    }
}

impl std::fmt::Display for VehicleOrientation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The samples taken while the vehicle rested in one orientation.
#[derive(Clone, Copy, Debug)]
pub struct OrientationSamples<'a> {
    pub orientation: VehicleOrientation,
    pub samples: &'a [ImuSample],
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AccelSettings {
    pub still: StillLimits,
    /// Largest angle between a mean reading and its orientation's expected axis (degrees).
    pub max_axis_error_deg: f64,
    /// Largest offset per axis (m/s²); ArduPilot's accelerometer calibration allows 3.5.
    pub max_offset_m_s2: f64,
    /// Scales outside `1 ± max_scale_error` are refused (ArduPilot: 0.8..1.2).
    pub max_scale_error: f64,
    /// Largest RMS of the affine fit's residual over the six means (m/s²): more means the
    /// vehicle was not set down square in some orientation.
    pub max_residual_m_s2: f64,
}

impl Default for AccelSettings {
    fn default() -> AccelSettings {
        AccelSettings {
            still: StillLimits::default(),
            max_axis_error_deg: 15.0,
            max_offset_m_s2: 3.5,
            max_scale_error: 0.2,
            max_residual_m_s2: 0.5,
        }
    }
}

/// What one orientation contributed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrientationFigure {
    pub orientation: VehicleOrientation,
    /// Angle between its mean reading and the expected axis (degrees).
    pub axis_error_deg: f64,
    /// Magnitude of its mean after calibration minus 1 g (m/s²).
    pub gravity_error_m_s2: f64,
    pub window: StillWindow,
}

/// An accelerometer calibration and how good it is.
#[derive(Clone, Debug, PartialEq)]
pub struct AccelFit {
    pub calibration: AccelCalibration,
    /// RMS over the six means of `mean − (T · expected + offset)` (m/s²).
    pub residual_m_s2: f64,
    /// RMS over the six means of `|calibrated mean| − 1 g` (m/s²).
    pub gravity_rms_m_s2: f64,
    /// Angle of the rotation left in T after the scales are taken out (degrees): the board's
    /// tilt against the airframe, which board-level calibration removes (roll and pitch).
    pub misalignment_deg: f64,
    pub orientations: Vec<OrientationFigure>,
}

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum AccelCalError {
    #[error("no samples with the vehicle {0}: all six orientations are needed")]
    Missing(VehicleOrientation),
    #[error("the vehicle {0} was given twice")]
    Twice(VehicleOrientation),
    #[error("with the vehicle {orientation}: {source}")]
    NotStill {
        orientation: VehicleOrientation,
        #[source]
        source: NotStill,
    },
    #[error(
        "with the vehicle {orientation} the accelerometer points {angle_deg:.1}° away from the expected axis (at most {max_deg}°): set it down {orientation}"
    )]
    OffAxis { orientation: VehicleOrientation, angle_deg: f64, max_deg: f64 },
    #[error("{axis} axis offset {offset_m_s2:.3} m/s² exceeds {max_m_s2} m/s²")]
    OffsetTooLarge { axis: &'static str, offset_m_s2: f64, max_m_s2: f64 },
    #[error("{axis} axis scale {scale:.4} is outside 1 ± {max_error}")]
    ScaleOutOfRange { axis: &'static str, scale: f64, max_error: f64 },
    #[error(
        "the six orientations disagree by {residual_m_s2:.3} m/s² RMS (at most {max_m_s2}): set each down square and still"
    )]
    ResidualTooHigh { residual_m_s2: f64, max_m_s2: f64 },
    #[error("accelerometer calibration: {0}")]
    Invalid(#[from] InvalidCalibration),
}

/// Offsets and scales from one still window per orientation (all six, any order).
pub fn calibrate_accel(
    captures: &[OrientationSamples<'_>],
    settings: &AccelSettings,
) -> Result<AccelFit, AccelCalError> {
    let mut windows: Vec<(VehicleOrientation, StillWindow, f64)> = Vec::with_capacity(6);
    for orientation in VehicleOrientation::ALL {
        let mut given = captures.iter().filter(|c| c.orientation == orientation);
        let capture = given.next().ok_or(AccelCalError::Missing(orientation))?;
        if given.next().is_some() {
            return Err(AccelCalError::Twice(orientation));
        }
        let window = still_window(capture.samples, &settings.still)
            .map_err(|source| AccelCalError::NotStill { orientation, source })?;
        let mean = Vector3::from(window.accel_mean_m_s2);
        let expected = Vector3::from(orientation.expected_m_s2());
        let angle_deg = mean.angle(&expected).to_degrees();
        if exceeds(angle_deg, settings.max_axis_error_deg) {
            return Err(AccelCalError::OffAxis {
                orientation,
                angle_deg,
                max_deg: settings.max_axis_error_deg,
            });
        }
        windows.push((orientation, window, angle_deg));
    }

    // Per sensor axis i: mean_k[i] = T_i · expected_k + offset_i, four unknowns over six means.
    // The design rows (expected_k, 1) are ±g along each axis once each way, so the normal
    // matrix is diag(2g², 2g², 2g², 6) and the least-squares solution is in closed form.
    let g2 = 2.0 * GRAVITY_M_S2 * GRAVITY_M_S2;
    let mut t = Matrix3::<f64>::zeros();
    let mut sum = Vector3::<f64>::zeros();
    for (orientation, window, _) in &windows {
        let mean = Vector3::from(window.accel_mean_m_s2);
        t += mean * Vector3::from(orientation.expected_m_s2()).transpose() / g2;
        sum += mean;
    }
    let offset: [f64; 3] = (sum / 6.0).into();
    let scale: [f64; 3] = std::array::from_fn(|i| t.row(i).norm());

    for axis in 0..3 {
        if exceeds(offset[axis].abs(), settings.max_offset_m_s2) {
            return Err(AccelCalError::OffsetTooLarge {
                axis: AXES[axis],
                offset_m_s2: offset[axis],
                max_m_s2: settings.max_offset_m_s2,
            });
        }
        if exceeds((scale[axis] - 1.0).abs(), settings.max_scale_error) {
            return Err(AccelCalError::ScaleOutOfRange {
                axis: AXES[axis],
                scale: scale[axis],
                max_error: settings.max_scale_error,
            });
        }
    }
    let calibration = AccelCalibration::new(offset, scale)?;

    let mut residual_sq = 0.0;
    let mut gravity_sq = 0.0;
    let mut orientations = Vec::with_capacity(6);
    for (orientation, window, axis_error_deg) in windows {
        let mean = Vector3::from(window.accel_mean_m_s2);
        let predicted = t * Vector3::from(orientation.expected_m_s2()) + Vector3::from(offset);
        residual_sq += (mean - predicted).norm_squared();
        let gravity_error_m_s2 =
            Vector3::from(calibration.apply(window.accel_mean_m_s2)).norm() - GRAVITY_M_S2;
        gravity_sq += gravity_error_m_s2 * gravity_error_m_s2;
        orientations.push(OrientationFigure { orientation, axis_error_deg, gravity_error_m_s2, window });
    }
    let residual_m_s2 = (residual_sq / 6.0).sqrt();
    if exceeds(residual_m_s2, settings.max_residual_m_s2) {
        return Err(AccelCalError::ResidualTooHigh { residual_m_s2, max_m_s2: settings.max_residual_m_s2 });
    }
    let unscaled = Matrix3::from_diagonal(&Vector3::from(scale.map(|s| 1.0 / s))) * t;
    let misalignment_deg = Rotation3::from_matrix(&unscaled).angle().to_degrees();
    Ok(AccelFit {
        calibration,
        residual_m_s2,
        gravity_rms_m_s2: (gravity_sq / 6.0).sqrt(),
        misalignment_deg,
        orientations,
    })
}
