//! Full-scale ranges, low-pass settings and raw → SI conversion (MPU-9250 product
//! specification PS-MPU-9250A-01 §3.1 "Gyroscope specifications", §3.2 "Accelerometer
//! specifications", register map §4.5–4.8 and §4.23 for temperature).

use kestrel_proto::units::GRAVITY_M_S2;

/// Temperature sensitivity (LSB/°C), with 0 LSB at 21 °C (PS §3.4.2; RM §4.22).
pub const TEMP_SENSITIVITY_LSB_C: f64 = 333.87;
/// Temperature at a raw reading of 0 (°C).
pub const TEMP_OFFSET_C: f64 = 21.0;

/// Gyro full scale (`GYRO_FS_SEL`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum GyroRange {
    Dps250,
    Dps500,
    Dps1000,
    Dps2000,
}

impl GyroRange {
    /// `GYRO_CONFIG` value: `FS_SEL` in bits 4:3, `FCHOICE_B` = 0 (DLPF on).
    pub fn register(self) -> u8 {
        (self as u8) << 3
    }

    /// Sensitivity (LSB per °/s): 131, 65.5, 32.8, 16.4.
    pub fn lsb_per_dps(self) -> f64 {
        match self {
            GyroRange::Dps250 => 131.0,
            GyroRange::Dps500 => 65.5,
            GyroRange::Dps1000 => 32.8,
            GyroRange::Dps2000 => 16.4,
        }
    }

    /// Rate of a raw count (rad/s).
    pub fn rad_s(self, raw: i16) -> f64 {
        (f64::from(raw) / self.lsb_per_dps()).to_radians()
    }
}

/// Accelerometer full scale (`ACCEL_FS_SEL`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum AccelRange {
    G2,
    G4,
    G8,
    G16,
}

impl AccelRange {
    /// `ACCEL_CONFIG` value: `ACCEL_FS_SEL` in bits 4:3.
    pub fn register(self) -> u8 {
        (self as u8) << 3
    }

    /// Sensitivity (LSB per g): 16384, 8192, 4096, 2048.
    pub fn lsb_per_g(self) -> f64 {
        16_384.0 / f64::from(1u16 << (self as u8))
    }

    /// Specific force of a raw count (m/s²).
    pub fn m_s2(self, raw: i16) -> f64 {
        f64::from(raw) / self.lsb_per_g() * GRAVITY_M_S2
    }
}

/// Digital low-pass filter of gyro and accelerometer, by gyro bandwidth; every setting keeps
/// the 1 kHz internal rate (RM §4.5 table, §4.8 table).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Dlpf {
    Hz184,
    Hz92,
    Hz41,
    Hz20,
    Hz10,
    Hz5,
}

impl Dlpf {
    /// `DLPF_CFG` for `CONFIG` and `A_DLPFCFG` for `ACCEL_CONFIG2` (same codes 1..6; accel
    /// bandwidths 218, 99, 44.8, 21.2, 10.2, 5.05 Hz).
    pub fn register(self) -> u8 {
        self as u8 + 1
    }
}

/// Whether a raw count sits at the end of the range, i.e. the true value may be beyond it.
pub fn is_clipped(raw: i16) -> bool {
    raw == i16::MAX || raw == i16::MIN
}

/// Die temperature of a raw count (°C).
pub fn temperature_c(raw: i16) -> f64 {
    f64::from(raw) / TEMP_SENSITIVITY_LSB_C + TEMP_OFFSET_C
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_scale_and_sensitivity() {
        assert_eq!(GyroRange::Dps2000.register(), 0x18);
        assert_eq!(AccelRange::G16.register(), 0x18);
        assert_eq!(AccelRange::G16.lsb_per_g(), 2048.0);
        assert_eq!(AccelRange::G2.lsb_per_g(), 16_384.0);
        assert!((GyroRange::Dps2000.rad_s(164) - 10f64.to_radians()).abs() < 1e-12);
        assert!((AccelRange::G16.m_s2(2048) - GRAVITY_M_S2).abs() < 1e-12);
        // Full scale: 32767 / 16.4 ≈ 1998 °/s, 32767 / 2048 ≈ 16 g.
        assert!((GyroRange::Dps2000.rad_s(i16::MAX).to_degrees() - 1998.0).abs() < 0.1);
        assert_eq!(Dlpf::Hz92.register(), 2);
        assert_eq!(temperature_c(0), 21.0);
        assert!(is_clipped(i16::MIN) && is_clipped(i16::MAX) && !is_clipped(32_766));
    }
}
