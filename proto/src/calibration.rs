//! Sensor calibrations as they are applied: plain, checked values with one `apply` each, so the
//! hardware drivers and the simulator's sensor path correct readings by the same arithmetic.
//!
//! The fits that produce them live in `kestrel_sensors::calibration`. Every calibration works in
//! the *sensor board's* frame (the FRD axes a driver reports after its chip → body axis map,
//! before the board's small tilt against the airframe is removed); [`BoardLevel`] then turns
//! the board's frame into the airframe's. A driver applies, per sample: [`GyroCalibration`] / [`AccelCalibration`] / [`MagCalibration`], then
//! [`BoardLevel::apply`].

use nalgebra::{Matrix3, Rotation3, Vector3};
use serde::{Deserialize, Serialize};

use crate::messages::{ImuSample, MagSample};

/// A calibration value that cannot be applied.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum InvalidCalibration {
    #[error("{field} must be finite, got {value:?}")]
    NotFinite { field: &'static str, value: Vec<f64> },
    #[error(
        "soft_iron {matrix:?} is singular or mirrors (determinant {determinant}); it must be invertible with a positive determinant"
    )]
    SoftIronSingular { matrix: [[f64; 3]; 3], determinant: f64 },
    #[error(
        "accel_scale[{axis}] = {scale} is outside 0.5..=2: not a scale error, a wrong range or a broken axis"
    )]
    AccelScale { axis: usize, scale: f64 },
}

fn finite(field: &'static str, values: &[f64]) -> Result<(), InvalidCalibration> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(InvalidCalibration::NotFinite { field, value: values.to_vec() })
    }
}

/// Magnetometer hard- and soft-iron correction, modelled as
/// `measured = soft_iron · true + hard_iron_gauss` in the sensor board's frame, and applied as
/// `corrected = soft_iron⁻¹ · (measured − hard_iron_gauss)` (gauss).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "MagCalibrationValues", into = "MagCalibrationValues")]
pub struct MagCalibration {
    values: MagCalibrationValues,
    /// `soft_iron⁻¹`, computed once when the values are checked.
    soft_iron_inverse: Matrix3<f64>,
}

/// The stored form of a [`MagCalibration`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MagCalibrationValues {
    /// Constant field of the airframe itself, board frame (gauss).
    pub hard_iron_gauss: [f64; 3],
    /// How the airframe's soft iron bends and scales the true field (rows: board FRD axes).
    pub soft_iron: [[f64; 3]; 3],
}

impl MagCalibration {
    /// No correction.
    pub fn identity() -> MagCalibration {
        MagCalibration {
            values: MagCalibrationValues {
                hard_iron_gauss: [0.0; 3],
                soft_iron: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            },
            soft_iron_inverse: Matrix3::identity(),
        }
    }

    /// Checks `hard_iron_gauss` (finite) and `soft_iron` (finite, invertible, not mirroring).
    pub fn new(
        hard_iron_gauss: [f64; 3],
        soft_iron: [[f64; 3]; 3],
    ) -> Result<MagCalibration, InvalidCalibration> {
        finite("hard_iron_gauss", &hard_iron_gauss)?;
        finite("soft_iron", soft_iron.as_flattened())?;
        let matrix = matrix3(&soft_iron);
        let determinant = matrix.determinant();
        let singular = InvalidCalibration::SoftIronSingular { matrix: soft_iron, determinant };
        // Soft iron changes the field by tens of percent; a determinant near zero is a typo.
        if determinant.is_nan() || determinant <= 1e-3 {
            return Err(singular);
        }
        let soft_iron_inverse = matrix.try_inverse().ok_or(singular)?;
        Ok(MagCalibration { values: MagCalibrationValues { hard_iron_gauss, soft_iron }, soft_iron_inverse })
    }

    /// The hard-iron offset, board frame (gauss).
    pub fn hard_iron_gauss(&self) -> [f64; 3] {
        self.values.hard_iron_gauss
    }

    /// The soft-iron matrix (dimensionless).
    pub fn soft_iron(&self) -> [[f64; 3]; 3] {
        self.values.soft_iron
    }

    /// The true field (gauss, board frame) of a `measured_gauss` reading (gauss, board frame).
    pub fn apply(&self, measured_gauss: [f64; 3]) -> [f64; 3] {
        let offset = Vector3::from(measured_gauss) - Vector3::from(self.values.hard_iron_gauss);
        (self.soft_iron_inverse * offset).into()
    }
}

impl Default for MagCalibration {
    fn default() -> MagCalibration {
        MagCalibration::identity()
    }
}

impl TryFrom<MagCalibrationValues> for MagCalibration {
    type Error = InvalidCalibration;
    fn try_from(v: MagCalibrationValues) -> Result<MagCalibration, InvalidCalibration> {
        MagCalibration::new(v.hard_iron_gauss, v.soft_iron)
    }
}

impl From<MagCalibration> for MagCalibrationValues {
    fn from(c: MagCalibration) -> MagCalibrationValues {
        c.values
    }
}

/// Accelerometer offset and per-axis scale, modelled as
/// `measured = accel_scale ⊙ true + accel_offset_m_s2` in the board frame and applied as
/// `corrected = (measured − accel_offset_m_s2) ⊘ accel_scale` (m/s²).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "AccelCalibrationValues", into = "AccelCalibrationValues")]
pub struct AccelCalibration {
    values: AccelCalibrationValues,
}

/// The stored form of an [`AccelCalibration`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AccelCalibrationValues {
    /// Reading at zero specific force, board frame (m/s²).
    pub accel_offset_m_s2: [f64; 3],
    /// Reading per unit of true specific force, per board axis (dimensionless, near 1).
    pub accel_scale: [f64; 3],
}

impl AccelCalibration {
    /// No correction.
    pub fn identity() -> AccelCalibration {
        AccelCalibration {
            values: AccelCalibrationValues { accel_offset_m_s2: [0.0; 3], accel_scale: [1.0; 3] },
        }
    }

    /// Checks that offsets are finite and each scale lies within 0.5..=2.
    pub fn new(
        accel_offset_m_s2: [f64; 3],
        accel_scale: [f64; 3],
    ) -> Result<AccelCalibration, InvalidCalibration> {
        finite("accel_offset_m_s2", &accel_offset_m_s2)?;
        finite("accel_scale", &accel_scale)?;
        if let Some((axis, &scale)) = accel_scale.iter().enumerate().find(|(_, s)| !(0.5..=2.0).contains(*s))
        {
            return Err(InvalidCalibration::AccelScale { axis, scale });
        }
        Ok(AccelCalibration { values: AccelCalibrationValues { accel_offset_m_s2, accel_scale } })
    }

    /// The offset, board frame (m/s²).
    pub fn offset_m_s2(&self) -> [f64; 3] {
        self.values.accel_offset_m_s2
    }

    /// The per-axis scale.
    pub fn scale(&self) -> [f64; 3] {
        self.values.accel_scale
    }

    /// The true specific force (m/s², board frame) of a `measured_m_s2` reading.
    pub fn apply(&self, measured_m_s2: [f64; 3]) -> [f64; 3] {
        let v = &self.values;
        std::array::from_fn(|i| (measured_m_s2[i] - v.accel_offset_m_s2[i]) / v.accel_scale[i])
    }
}

impl Default for AccelCalibration {
    fn default() -> AccelCalibration {
        AccelCalibration::identity()
    }
}

impl TryFrom<AccelCalibrationValues> for AccelCalibration {
    type Error = InvalidCalibration;
    fn try_from(v: AccelCalibrationValues) -> Result<AccelCalibration, InvalidCalibration> {
        AccelCalibration::new(v.accel_offset_m_s2, v.accel_scale)
    }
}

impl From<AccelCalibration> for AccelCalibrationValues {
    fn from(c: AccelCalibration) -> AccelCalibrationValues {
        c.values
    }
}

/// Gyro offset at rest, board frame: `corrected = measured − gyro_offset_rad_s` (rad/s).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GyroCalibration {
    /// What the gyro reads at rest (rad/s).
    pub gyro_offset_rad_s: [f64; 3],
}

impl GyroCalibration {
    /// The true rate (rad/s, board frame) of a `measured_rad_s` reading.
    pub fn apply(&self, measured_rad_s: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|i| measured_rad_s[i] - self.gyro_offset_rad_s[i])
    }
}

/// The sensor board's roll and pitch against the airframe, found with the vehicle standing on
/// level ground: `airframe = R(roll, pitch) · board`, R the aerospace Z-Y-X rotation with zero
/// yaw (roll about forward, pitch about right). Applied to IMU and magnetometer alike: the
/// MPU-9250 carries the AK8963 on the same board.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "BoardLevelValues", into = "BoardLevelValues")]
pub struct BoardLevel {
    values: BoardLevelValues,
    /// Board → airframe, computed once.
    rotation: Rotation3<f64>,
}

/// The stored form of a [`BoardLevel`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoardLevelValues {
    /// Board roll against the airframe, right side down positive (degrees).
    pub roll_deg: f64,
    /// Board pitch against the airframe, nose up positive (degrees).
    pub pitch_deg: f64,
}

impl BoardLevel {
    /// A level board.
    pub fn identity() -> BoardLevel {
        BoardLevel { values: BoardLevelValues::default(), rotation: Rotation3::identity() }
    }

    /// Checks that both angles are finite.
    pub fn new(roll_deg: f64, pitch_deg: f64) -> Result<BoardLevel, InvalidCalibration> {
        finite("board level roll_deg, pitch_deg", &[roll_deg, pitch_deg])?;
        let rotation = Rotation3::from_euler_angles(roll_deg.to_radians(), pitch_deg.to_radians(), 0.0);
        Ok(BoardLevel { values: BoardLevelValues { roll_deg, pitch_deg }, rotation })
    }

    pub fn roll_deg(&self) -> f64 {
        self.values.roll_deg
    }

    pub fn pitch_deg(&self) -> f64 {
        self.values.pitch_deg
    }

    /// A board-frame vector (any unit: m/s², rad/s, gauss) in the airframe's FRD.
    pub fn apply(&self, board: [f64; 3]) -> [f64; 3] {
        (self.rotation * Vector3::from(board)).into()
    }
}

impl Default for BoardLevel {
    fn default() -> BoardLevel {
        BoardLevel::identity()
    }
}

impl TryFrom<BoardLevelValues> for BoardLevel {
    type Error = InvalidCalibration;
    fn try_from(v: BoardLevelValues) -> Result<BoardLevel, InvalidCalibration> {
        BoardLevel::new(v.roll_deg, v.pitch_deg)
    }
}

impl From<BoardLevel> for BoardLevelValues {
    fn from(c: BoardLevel) -> BoardLevelValues {
        c.values
    }
}

/// Every calibration of one sensor board, applied in the one order drivers and the simulator
/// share: each sensor's own correction in the board's axes, then the board level.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensorCalibration {
    pub gyro: GyroCalibration,
    pub accel: AccelCalibration,
    pub mag: MagCalibration,
    pub level: BoardLevel,
}

impl SensorCalibration {
    /// `sample` with calibrated gyro and accelerometer, in the airframe's FRD.
    pub fn apply_imu(&self, sample: &ImuSample) -> ImuSample {
        ImuSample {
            gyro_rad_s: self.level.apply(self.gyro.apply(sample.gyro_rad_s)),
            accel_m_s2: self.level.apply(self.accel.apply(sample.accel_m_s2)),
            ..*sample
        }
    }

    /// `sample` with the calibrated field, in the airframe's FRD.
    pub fn apply_mag(&self, sample: &MagSample) -> MagSample {
        MagSample { field_gauss: self.level.apply(self.mag.apply(sample.field_gauss)), ..*sample }
    }
}

/// A row-major `[[f64; 3]; 3]` as a matrix.
pub fn matrix3(rows: &[[f64; 3]; 3]) -> Matrix3<f64> {
    Matrix3::from_fn(|r, c| rows[r][c])
}

/// A matrix as row-major `[[f64; 3]; 3]`.
pub fn rows3(m: &Matrix3<f64>) -> [[f64; 3]; 3] {
    std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_calibration_undoes_its_model() {
        let soft = [[1.1, 0.05, -0.05], [0.05, 0.9, 0.05], [-0.05, 0.05, 1.05]];
        let mag = MagCalibration::new([0.15, -0.1, 0.2], soft).expect("valid");
        let truth = Vector3::new(0.3, -0.2, 0.25);
        let measured = matrix3(&soft) * truth + Vector3::new(0.15, -0.1, 0.2);
        let back = Vector3::from(mag.apply(measured.into()));
        assert!((back - truth).norm() < 1e-12, "{back}");

        let accel = AccelCalibration::new([0.3, -0.3, 0.3], [1.02, 0.98, 1.02]).expect("valid");
        let back = accel.apply([1.02 * 1.0 + 0.3, 0.98 * -2.0 - 0.3, 1.02 * -9.8 + 0.3]);
        for (b, t) in back.iter().zip([1.0, -2.0, -9.8]) {
            assert!((b - t).abs() < 1e-12, "{back:?}");
        }
        let gyro = GyroCalibration { gyro_offset_rad_s: [0.01, -0.02, 0.03] };
        assert_eq!(gyro.apply([0.01, -0.02, 0.03]), [0.0; 3]);

        // A board rolled 3° right side down reads gravity leaning towards its left; the trim
        // turns it back to straight down.
        let level = BoardLevel::new(3.0, 0.0).expect("valid");
        let g = crate::units::GRAVITY_M_S2;
        let reading = [0.0, -g * 3f64.to_radians().sin(), -g * 3f64.to_radians().cos()];
        let airframe = level.apply(reading);
        assert!(airframe[0].abs() < 1e-12 && airframe[1].abs() < 1e-12, "{airframe:?}");
    }

    #[test]
    fn bad_values_are_refused_and_round_trip_through_serde() {
        assert!(matches!(
            MagCalibration::new([0.0; 3], [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]]),
            Err(InvalidCalibration::SoftIronSingular { .. })
        ));
        assert!(matches!(
            MagCalibration::new([f64::NAN, 0.0, 0.0], MagCalibration::identity().soft_iron()),
            Err(InvalidCalibration::NotFinite { field: "hard_iron_gauss", .. })
        ));
        assert!(matches!(
            AccelCalibration::new([0.0; 3], [1.0, 0.0, 1.0]),
            Err(InvalidCalibration::AccelScale { axis: 1, .. })
        ));
        assert!(BoardLevel::new(f64::INFINITY, 0.0).is_err());
        let mag = MagCalibration::new([0.1, 0.2, 0.3], [[1.1, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.9]])
            .expect("valid");
        let json = serde_json::to_string(&mag).expect("serialise");
        assert_eq!(serde_json::from_str::<MagCalibration>(&json).expect("parse"), mag);
        let bad = json.replace("1.1", "0.0");
        assert!(serde_json::from_str::<MagCalibration>(&bad).is_err(), "{bad}");

        // A whole board's calibration persists and reloads as it was; missing parts default
        // to no correction.
        let board = SensorCalibration {
            gyro: GyroCalibration { gyro_offset_rad_s: [0.01, -0.02, 0.03] },
            accel: AccelCalibration::new([0.3, -0.3, 0.3], [1.02, 0.98, 1.02]).expect("valid"),
            mag,
            level: BoardLevel::new(2.0, -2.24).expect("valid"),
        };
        let json = serde_json::to_string(&board).expect("serialise");
        assert_eq!(serde_json::from_str::<SensorCalibration>(&json).expect("parse"), board);
        let partial: SensorCalibration =
            serde_json::from_str(r#"{"level": {"roll_deg": 1.0, "pitch_deg": 0.0}}"#)
                .expect("parse a partial calibration");
        assert_eq!((partial.mag, partial.level.roll_deg()), (MagCalibration::identity(), 1.0));
    }
}
