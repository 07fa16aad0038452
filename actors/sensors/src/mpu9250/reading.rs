//! One burst read of the MPU-9250 (accelerometer, temperature, gyro and the AK8963 bytes the
//! I2C master fetched) and its conversion to SI units in body FRD.

use kestrel_proto::Time;

use crate::ak8963::{self, Ak8963Reading};
use crate::axis_map::AxisMap;
use crate::mpu9250::scale::{AccelRange, GyroRange, is_clipped, temperature_c};

/// Bytes of one burst read from `ACCEL_XOUT_H`: 14 of motion data and 8 of magnetometer.
pub const BURST_LEN: usize = 14 + ak8963::READ_LEN;

/// Raw counts in chip axes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RawImu {
    pub accel: [i16; 3],
    pub temperature: i16,
    pub gyro: [i16; 3],
    /// The magnetometer bytes, when the I2C master is reading the AK8963.
    pub mag: Option<Ak8963Reading>,
}

impl RawImu {
    /// Parses a burst read; `with_mag` says whether the last 8 bytes are AK8963 data.
    pub fn parse(bytes: &[u8; BURST_LEN], with_mag: bool) -> RawImu {
        let be = |i: usize| i16::from_be_bytes([bytes[2 * i], bytes[2 * i + 1]]);
        let mut mag_bytes = [0u8; ak8963::READ_LEN];
        mag_bytes.copy_from_slice(&bytes[14..]);
        RawImu {
            accel: [be(0), be(1), be(2)],
            temperature: be(3),
            gyro: [be(4), be(5), be(6)],
            mag: with_mag.then(|| Ak8963Reading::parse(&mag_bytes)),
        }
    }
}

/// One sample in SI units and body FRD.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuReading {
    /// When the registers were read.
    pub time: Time,
    /// Angular rate about forward, right, down (rad/s).
    pub gyro_frd_rad_s: [f64; 3],
    /// Specific force along forward, right, down (m/s²).
    pub accel_frd_m_s2: [f64; 3],
    /// Die temperature (°C).
    pub temperature_c: f64,
    /// Per body axis: the gyro count was at the end of its range.
    pub gyro_clipped: [bool; 3],
    /// Per body axis: the accelerometer count was at the end of its range.
    pub accel_clipped: [bool; 3],
    /// A new, valid magnetometer measurement along forward, right, down (gauss).
    pub mag_frd_gauss: Option<[f64; 3]>,
}

impl ImuReading {
    /// Converts `raw` read at `time`, with the configured ranges, axes and the AK8963's
    /// fuse-ROM sensitivity adjustment.
    pub fn from_raw(
        raw: &RawImu,
        time: Time,
        gyro: GyroRange,
        accel: AccelRange,
        axes: &AxisMap,
        mag_adjustment: [f64; 3],
    ) -> ImuReading {
        let clipped = |counts: [i16; 3]| {
            let chip = counts.map(|c| if is_clipped(c) { 1.0 } else { 0.0 });
            axes.to_frd(chip).map(|c| c != 0.0)
        };
        ImuReading {
            time,
            gyro_frd_rad_s: axes.to_frd(raw.gyro.map(|c| gyro.rad_s(c))),
            accel_frd_m_s2: axes.to_frd(raw.accel.map(|c| accel.m_s2(c))),
            temperature_c: temperature_c(raw.temperature),
            gyro_clipped: clipped(raw.gyro),
            accel_clipped: clipped(raw.accel),
            mag_frd_gauss: raw
                .mag
                .filter(|m| m.data_ready)
                .and_then(|m| m.to_accel_axes(mag_adjustment))
                .map(|chip| axes.to_frd(chip)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kestrel_proto::units::GRAVITY_M_S2;

    #[test]
    fn level_and_still_with_a_clipped_roll_rate() {
        let mut bytes = [0u8; BURST_LEN];
        bytes[4..6].copy_from_slice(&2048i16.to_be_bytes()); // +1 g on chip Z
        bytes[8..10].copy_from_slice(&i16::MAX.to_be_bytes()); // gyro X at full scale
        bytes[14] = 0x01; // ST1.DRDY
        bytes[15..17].copy_from_slice(&200i16.to_le_bytes()); // mag X = accel Y
        let raw = RawImu::parse(&bytes, true);
        let r = ImuReading::from_raw(
            &raw,
            Time::ZERO,
            GyroRange::Dps2000,
            AccelRange::G16,
            &AxisMap::default(),
            [1.0; 3],
        );
        assert_eq!(r.accel_frd_m_s2, [0.0, -0.0, -GRAVITY_M_S2]);
        assert_eq!(r.gyro_clipped, [true, false, false]);
        assert_eq!(r.accel_clipped, [false; 3]);
        assert!((r.gyro_frd_rad_s[0] - (32_767.0 / 16.4f64).to_radians()).abs() < 1e-12);
        // 0.3 G on accel Y, which is body left: −0.3 G on body right.
        let mag = r.mag_frd_gauss.expect("fresh sample");
        assert!((mag[1] + 0.3).abs() < 1e-12 && mag[0] == 0.0, "{mag:?}");
        let without = RawImu::parse(&bytes, false);
        assert_eq!(without.mag, None);
    }
}
