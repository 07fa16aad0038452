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

/// A board's calibration as the live parameters that hold it, in ArduPilot's names, units and
/// sense (so a parameter file reads as ArduPilot's does):
///
/// * `COMPASS_OFS_X/Y/Z` — milligauss *added* to the reading (= −hard iron);
///   `COMPASS_DIA_X/Y/Z`, `COMPASS_ODI_X/Y/Z` — the symmetric correction matrix applied after
///   (diagonal; xy, xz, yz), = soft_iron⁻¹ (ArduPilot's `Compass::_offset`, `_diagonals`,
///   `_offdiagonals`);
/// * `INS_ACCOFFS_X/Y/Z` — m/s² subtracted, then `INS_ACCSCAL_X/Y/Z` multiplied (= 1 / our
///   `accel_scale`), as `AP_InertialSensor_Backend::_rotate_and_correct_accel` does;
/// * `INS_GYROFFS_X/Y/Z` — rad/s subtracted;
/// * `AHRS_TRIM_X/Y` — the board's roll and pitch against the airframe (rad), our [`BoardLevel`]
///   (ArduPilot's name and unit; the sign is the board's tilt, not its correction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalibrationParams {
    pub compass_ofs_mgauss: [f64; 3],
    pub compass_dia: [f64; 3],
    pub compass_odi: [f64; 3],
    pub ins_accoffs_m_s2: [f64; 3],
    pub ins_accscal: [f64; 3],
    pub ins_gyroffs_rad_s: [f64; 3],
    pub ahrs_trim_rad: [f64; 2],
}

impl Default for CalibrationParams {
    fn default() -> CalibrationParams {
        CalibrationParams::from_calibration(&SensorCalibration::default())
    }
}

/// ArduPilot's limits where it has them: `COMPASS_OFFS_MAX` 1800 mG, accelerometer offsets
/// 3.5 m/s² and scales 0.8..1.2 (`AccelCalibrator`), trims ±10°.
macro_rules! cal_param {
    ($name:literal, $unit:literal, $min:expr, $max:expr, $desc:literal, $field:ident [$i:literal]) => {
        crate::param_def::ParamDef {
            name: $name,
            unit: $unit,
            min: $min,
            max: $max,
            description: $desc,
            // The corrected samples would step under an estimator that realigns only on the
            // ground: set on the ground only.
            while_armed: crate::param_def::WhileArmed::Locked,
            get: |p: &CalibrationParams| p.$field[$i],
            set: |p: &mut CalibrationParams, v| p.$field[$i] = v,
        }
    };
}

/// The live parameters of [`CalibrationParams`], declared by whatever owns the sensor path (the
/// simulator, the MPU-9250 driver).
pub static CALIBRATION_PARAMS: [crate::param_def::ParamDef<CalibrationParams>; 20] = [
    cal_param!(
        "COMPASS_OFS_X",
        "mG",
        -1800.0,
        1800.0,
        "compass offset added, forward",
        compass_ofs_mgauss[0]
    ),
    cal_param!("COMPASS_OFS_Y", "mG", -1800.0, 1800.0, "compass offset added, right", compass_ofs_mgauss[1]),
    cal_param!("COMPASS_OFS_Z", "mG", -1800.0, 1800.0, "compass offset added, down", compass_ofs_mgauss[2]),
    cal_param!("COMPASS_DIA_X", "", 0.2, 5.0, "compass soft-iron correction xx", compass_dia[0]),
    cal_param!("COMPASS_DIA_Y", "", 0.2, 5.0, "compass soft-iron correction yy", compass_dia[1]),
    cal_param!("COMPASS_DIA_Z", "", 0.2, 5.0, "compass soft-iron correction zz", compass_dia[2]),
    cal_param!("COMPASS_ODI_X", "", -1.0, 1.0, "compass soft-iron correction xy", compass_odi[0]),
    cal_param!("COMPASS_ODI_Y", "", -1.0, 1.0, "compass soft-iron correction xz", compass_odi[1]),
    cal_param!("COMPASS_ODI_Z", "", -1.0, 1.0, "compass soft-iron correction yz", compass_odi[2]),
    cal_param!("INS_ACCOFFS_X", "m/s^2", -3.5, 3.5, "accelerometer offset, forward", ins_accoffs_m_s2[0]),
    cal_param!("INS_ACCOFFS_Y", "m/s^2", -3.5, 3.5, "accelerometer offset, right", ins_accoffs_m_s2[1]),
    cal_param!("INS_ACCOFFS_Z", "m/s^2", -3.5, 3.5, "accelerometer offset, down", ins_accoffs_m_s2[2]),
    cal_param!("INS_ACCSCAL_X", "", 0.8, 1.2, "accelerometer scale, forward", ins_accscal[0]),
    cal_param!("INS_ACCSCAL_Y", "", 0.8, 1.2, "accelerometer scale, right", ins_accscal[1]),
    cal_param!("INS_ACCSCAL_Z", "", 0.8, 1.2, "accelerometer scale, down", ins_accscal[2]),
    cal_param!("INS_GYROFFS_X", "rad/s", -0.5, 0.5, "gyro offset, forward", ins_gyroffs_rad_s[0]),
    cal_param!("INS_GYROFFS_Y", "rad/s", -0.5, 0.5, "gyro offset, right", ins_gyroffs_rad_s[1]),
    cal_param!("INS_GYROFFS_Z", "rad/s", -0.5, 0.5, "gyro offset, down", ins_gyroffs_rad_s[2]),
    cal_param!("AHRS_TRIM_X", "rad", -0.1745, 0.1745, "board roll against the airframe", ahrs_trim_rad[0]),
    cal_param!("AHRS_TRIM_Y", "rad", -0.1745, 0.1745, "board pitch against the airframe", ahrs_trim_rad[1]),
];

impl CalibrationParams {
    /// The parameters holding `c`.
    pub fn from_calibration(c: &SensorCalibration) -> CalibrationParams {
        let correction = matrix3(&c.mag.soft_iron()).try_inverse().unwrap_or_else(Matrix3::identity);
        let correction = (correction + correction.transpose()) / 2.0;
        CalibrationParams {
            compass_ofs_mgauss: c.mag.hard_iron_gauss().map(|h| -h * 1000.0),
            compass_dia: [correction[(0, 0)], correction[(1, 1)], correction[(2, 2)]],
            compass_odi: [correction[(0, 1)], correction[(0, 2)], correction[(1, 2)]],
            ins_accoffs_m_s2: c.accel.offset_m_s2(),
            ins_accscal: c.accel.scale().map(|s| 1.0 / s),
            ins_gyroffs_rad_s: c.gyro.gyro_offset_rad_s,
            ahrs_trim_rad: [c.level.roll_deg().to_radians(), c.level.pitch_deg().to_radians()],
        }
    }

    /// The calibration these parameters hold, checked.
    pub fn calibration(&self) -> Result<SensorCalibration, InvalidCalibration> {
        let [dx, dy, dz] = self.compass_dia;
        let [xy, xz, yz] = self.compass_odi;
        let correction = Matrix3::new(dx, xy, xz, xy, dy, yz, xz, yz, dz);
        let determinant = correction.determinant();
        let soft_iron = correction
            .try_inverse()
            .filter(|_| determinant > 1e-3)
            .ok_or(InvalidCalibration::SoftIronSingular { matrix: rows3(&correction), determinant })?;
        Ok(SensorCalibration {
            gyro: GyroCalibration { gyro_offset_rad_s: self.ins_gyroffs_rad_s },
            accel: AccelCalibration::new(self.ins_accoffs_m_s2, self.ins_accscal.map(|s| 1.0 / s))?,
            mag: MagCalibration::new(self.compass_ofs_mgauss.map(|o| -o / 1000.0), rows3(&soft_iron))?,
            level: BoardLevel::new(self.ahrs_trim_rad[0].to_degrees(), self.ahrs_trim_rad[1].to_degrees())?,
        })
    }

    /// The parameters with `name`'s value (unknown names are ignored): a declaration read back.
    pub fn with(mut self, name: &str, value: f64) -> CalibrationParams {
        if let Some(def) = CALIBRATION_PARAMS.iter().find(|d| d.name == name) {
            (def.set)(&mut self, value);
        }
        self
    }

    /// Whether the values of parameters starting with `prefix` differ from no correction:
    /// ArduPilot's pre-arm reads all-zero compass offsets as "not calibrated" (`Compass::configured`),
    /// and default accelerometer offsets and scales likewise.
    pub fn differs_from_default(&self, prefix: &str) -> bool {
        let default = CalibrationParams::default();
        CALIBRATION_PARAMS
            .iter()
            .filter(|d| d.name.starts_with(prefix))
            .any(|d| (d.get)(self) != (d.get)(&default))
    }

    /// `(name, value)` of every parameter starting with `prefix`.
    pub fn values(&self, prefix: &str) -> Vec<(String, f64)> {
        CALIBRATION_PARAMS
            .iter()
            .filter(|d| d.name.starts_with(prefix))
            .map(|d| (d.name.to_owned(), (d.get)(self)))
            .collect()
    }
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

    #[test]
    fn parameters_hold_a_calibration_in_ardupilots_sense() {
        let soft = [[1.1, 0.05, -0.05], [0.05, 0.9, 0.05], [-0.05, 0.05, 1.05]];
        let board = SensorCalibration {
            gyro: GyroCalibration { gyro_offset_rad_s: [0.01, -0.02, 0.03] },
            accel: AccelCalibration::new([0.3, -0.3, 0.3], [1.02, 0.98, 1.02]).expect("valid"),
            mag: MagCalibration::new([0.15, -0.1, 0.2], soft).expect("valid"),
            level: BoardLevel::new(3.0, -1.0).expect("valid"),
        };
        let p = CalibrationParams::from_calibration(&board);
        assert_eq!(p.compass_ofs_mgauss.map(f64::round), [-150.0, 100.0, -200.0]);
        assert!((p.ins_accscal[0] - 1.0 / 1.02).abs() < 1e-12);
        let raw = [0.4, -0.1, 0.3];
        // ArduPilot: (raw + offsets), then the correction matrix.
        let ardupilot = Matrix3::new(
            p.compass_dia[0],
            p.compass_odi[0],
            p.compass_odi[1],
            p.compass_odi[0],
            p.compass_dia[1],
            p.compass_odi[2],
            p.compass_odi[1],
            p.compass_odi[2],
            p.compass_dia[2],
        ) * (Vector3::from(raw) + Vector3::from(p.compass_ofs_mgauss) / 1000.0);
        let ours = Vector3::from(board.mag.apply(raw));
        assert!((ardupilot - ours).norm() < 1e-12, "{ardupilot} {ours}");
        let back = p.calibration().expect("valid");
        let again = CalibrationParams::from_calibration(&back);
        for d in &CALIBRATION_PARAMS {
            assert!(((d.get)(&p) - (d.get)(&again)).abs() < 1e-9, "{}", d.name);
        }
        let defaults = CalibrationParams::default();
        assert!(!defaults.differs_from_default("COMPASS_") && p.differs_from_default("COMPASS_"));
        assert_eq!(defaults.calibration().expect("identity"), SensorCalibration::default());
        assert!(defaults.with("COMPASS_DIA_X", 0.2).with("COMPASS_ODI_X", 1.0).calibration().is_err());
        assert_eq!(p.values("AHRS_TRIM").len(), 2);
    }
}
