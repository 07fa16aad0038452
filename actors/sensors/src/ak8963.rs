//! AKM AK8963 magnetometer inside the MPU-9250 (AK8963 datasheet MS1356-E-02 §8 "Registers"):
//! register map, the sensitivity adjustment from its fuse ROM (§8.3.11) and raw → gauss.
//!
//! Its axes differ from the accelerometer's (MPU-9250 product specification §9.1
//! "Orientation of axes"): X_mag = Y_accel, Y_mag = X_accel, Z_mag = −Z_accel.
//! [`Ak8963Reading::to_accel_axes`] undoes that so one [`AxisMap`](crate::axis_map::AxisMap)
//! serves both.

/// I2C address behind the MPU-9250's auxiliary master.
pub const ADDRESS: u8 = 0x0C;
/// Device id register; reads [`WIA_VALUE`].
pub const WIA: u8 = 0x00;
/// AKM's device id.
pub const WIA_VALUE: u8 = 0x48;
/// Status 1: `DRDY` (bit 0) new data, `DOR` (bit 1) data overrun.
pub const ST1: u8 = 0x02;
/// First data register; X, Y, Z little-endian i16.
pub const HXL: u8 = 0x03;
/// Status 2: `HOFL` (bit 3) magnetic overflow, `BITM` (bit 4) 16-bit output. Reading it
/// releases the data registers.
pub const ST2: u8 = 0x09;
/// Control 1: `BIT` (bit 4) output width, `MODE` (bits 3:0).
pub const CNTL1: u8 = 0x0A;
/// Control 2: `SRST` (bit 0) soft reset.
pub const CNTL2: u8 = 0x0B;
/// Fuse ROM sensitivity adjustment, X/Y/Z.
pub const ASAX: u8 = 0x10;

/// `CNTL1`: power down (required between mode changes).
pub const MODE_POWER_DOWN: u8 = 0x00;
/// `CNTL1`: fuse ROM access.
pub const MODE_FUSE_ROM: u8 = 0x0F;
/// `CNTL1`: 16-bit output, continuous measurement mode 2 (100 Hz).
pub const MODE_CONTINUOUS_100HZ_16BIT: u8 = 0x16;
/// `CNTL2`: soft reset.
pub const SRST: u8 = 0x01;
/// `ST2` overflow bit.
pub const HOFL: u8 = 0x08;
/// Bytes of one read from `ST1` through `ST2`.
pub const READ_LEN: usize = 8;

/// Resolution in 16-bit mode: 0.15 µT/LSB (§5.3) = 0.0015 gauss/LSB.
pub const GAUSS_PER_LSB_16BIT: f64 = 0.0015;

/// Sensitivity adjustment from the fuse ROM values `asa` (§8.3.11):
/// `H_adj = H · ((ASA − 128) · 0.5 / 128 + 1)`.
pub fn sensitivity_adjustment(asa: [u8; 3]) -> [f64; 3] {
    asa.map(|a| (f64::from(a) - 128.0) * 0.5 / 128.0 + 1.0)
}

/// One read of `ST1..=ST2`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Ak8963Reading {
    /// Raw X, Y, Z in the AK8963's own axes.
    pub raw: [i16; 3],
    /// `ST1.DRDY`: this is a new measurement.
    pub data_ready: bool,
    /// `ST2.HOFL`: |X|+|Y|+|Z| exceeded 4912 µT; the values are invalid.
    pub overflow: bool,
}

impl Ak8963Reading {
    /// Parses the 8 bytes `ST1, HXL, HXH, HYL, HYH, HZL, HZH, ST2`.
    pub fn parse(bytes: &[u8; READ_LEN]) -> Ak8963Reading {
        let axis = |i: usize| i16::from_le_bytes([bytes[1 + 2 * i], bytes[2 + 2 * i]]);
        Ak8963Reading {
            raw: [axis(0), axis(1), axis(2)],
            data_ready: bytes[0] & 0x01 != 0,
            overflow: bytes[7] & HOFL != 0,
        }
    }

    /// Field in the MPU-9250 accelerometer's axes (gauss), sensitivity-adjusted; `None` on
    /// overflow.
    pub fn to_accel_axes(&self, adjustment: [f64; 3]) -> Option<[f64; 3]> {
        if self.overflow {
            return None;
        }
        let g: [f64; 3] =
            std::array::from_fn(|i| f64::from(self.raw[i]) * adjustment[i] * GAUSS_PER_LSB_16BIT);
        Some([g[1], g[0], -g[2]])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fuse_rom_adjustment() {
        // ASA = 128 → ×1; 0 → ×0.5; 255 → ×(1 + 127/256).
        assert_eq!(sensitivity_adjustment([128, 0, 255]), [1.0, 0.5, 1.0 + 127.0 / 256.0]);
        // A typical part: ASA 176 → ×1.1875.
        assert_eq!(sensitivity_adjustment([176, 176, 165])[0], 1.1875);
    }

    #[test]
    fn raw_to_gauss_in_accel_axes() {
        // 200 LSB × 0.15 µT = 30 µT = 0.3 G on mag X, which is accel Y.
        let bytes = [0x01, 200, 0, 0x9C, 0xFF, 100, 0, 0x10];
        let reading = Ak8963Reading::parse(&bytes);
        assert_eq!(reading.raw, [200, -100, 100]);
        assert!(reading.data_ready && !reading.overflow);
        let field = reading.to_accel_axes([1.0; 3]).expect("no overflow");
        let expected = [-0.15, 0.3, -0.15];
        for (f, e) in field.iter().zip(expected) {
            assert!((f - e).abs() < 1e-12, "{field:?}");
        }
        let overflowed = Ak8963Reading::parse(&[0x01, 0, 0, 0, 0, 0, 0, 0x18]);
        assert_eq!(overflowed.to_accel_axes([1.0; 3]), None);
    }
}
