//! Bringing up the MPU-9250 over SPI and reading it.
//!
//! The sequence follows the register map and the reference drivers (PX4 `mpu9250`, ArduPilot
//! `AP_InertialSensor_Invensense`): reset, SPI-only mode, identity check, clock, ranges, low-pass
//! filter and rate, read-back of the range registers (a bus that returns garbage fails here,
//! not in flight); then the AK8963 through the auxiliary I2C master: soft reset, identity, fuse
//! ROM, 16-bit continuous 100 Hz, and slave 0 set to fetch `ST1..ST2` after every sample so a
//! single 22-byte burst from `ACCEL_XOUT_H` returns motion and field together.

use std::path::{Path, PathBuf};
use std::time::Duration;

use kestrel_proto::Time;

use crate::ak8963;
use crate::axis_map::AxisMap;
use crate::bus::{BusError, SpiBus, spi_read_registers, spi_write_register};
use crate::mpu9250::reading::{BURST_LEN, ImuReading, RawImu};
use crate::mpu9250::registers::*;
use crate::mpu9250::scale::{AccelRange, Dlpf, GyroRange};

/// Wait after `H_RESET` (register map §4.30 gives no figure; 100 ms as the reference drivers).
pub const RESET_TIME: Duration = Duration::from_millis(100);
/// Wait for one auxiliary I2C transaction to complete (one 1 kHz sample plus margin).
pub const SLAVE_TIME: Duration = Duration::from_millis(10);

/// How to configure the IMU.
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct Mpu9250Config {
    pub gyro_range: GyroRange,
    pub accel_range: AccelRange,
    pub dlpf: Dlpf,
    /// Output rate = 1 kHz / (1 + divider).
    pub sample_rate_divider: u8,
    /// Chip axes → body FRD.
    pub axes: AxisMap,
    /// Bring up the AK8963 and read it with every sample.
    pub magnetometer: bool,
}

impl Default for Mpu9250Config {
    /// ±2000 °/s, ±16 g, 92 Hz low-pass, 1 kHz, chip X forward, magnetometer on.
    fn default() -> Mpu9250Config {
        Mpu9250Config {
            gyro_range: GyroRange::Dps2000,
            accel_range: AccelRange::G16,
            dlpf: Dlpf::Hz92,
            sample_rate_divider: 0,
            axes: AxisMap::default(),
            magnetometer: true,
        }
    }
}

/// Why the IMU could not be used.
#[derive(Debug, thiserror::Error)]
pub enum Mpu9250Error {
    #[error("MPU-9250 bus transfer failed: {0}")]
    Bus(#[from] BusError),
    #[error("{}: WHO_AM_I reads {found:#04x}, expected 0x71 (MPU-9250) or 0x73 (MPU-9255): no such IMU on this bus", path.display())]
    Identity { path: PathBuf, found: u8 },
    #[error("{}: register {register:#04x} reads back {read:#04x} after writing {wrote:#04x}", path.display())]
    ReadBack { path: PathBuf, register: u8, wrote: u8, read: u8 },
    #[error("{}: AK8963 WIA reads {found:#04x} through the MPU-9250's I2C master, expected 0x48", path.display())]
    MagIdentity { path: PathBuf, found: u8 },
    #[error("invalid axis map {0:?}: each chip axis must be used once, with sign ±1")]
    AxisMap(AxisMap),
}

/// A configured MPU-9250.
pub struct Mpu9250<B> {
    bus: B,
    config: Mpu9250Config,
    /// AK8963 fuse-ROM sensitivity adjustment per axis; `None` without the magnetometer.
    mag_adjustment: Option<[f64; 3]>,
}

impl<B: SpiBus> Mpu9250<B> {
    /// Runs the configuration sequence, waiting through `sleep` where the chip needs time.
    pub fn new(
        mut bus: B,
        config: Mpu9250Config,
        sleep: &mut impl FnMut(Duration),
    ) -> Result<Mpu9250<B>, Mpu9250Error> {
        if !config.axes.is_valid() {
            return Err(Mpu9250Error::AxisMap(config.axes));
        }
        spi_write_register(&mut bus, PWR_MGMT_1, H_RESET)?;
        sleep(RESET_TIME);
        spi_write_register(&mut bus, USER_CTRL, I2C_IF_DIS)?;
        let found = read_register(&mut bus, WHO_AM_I)?;
        if !WHO_AM_I_VALUES.contains(&found) {
            return Err(Mpu9250Error::Identity { path: bus.path().to_path_buf(), found });
        }
        let settings = [
            (PWR_MGMT_1, CLKSEL_AUTO),
            (PWR_MGMT_2, 0x00),
            (CONFIG, config.dlpf.register()),
            (SMPLRT_DIV, config.sample_rate_divider),
            (GYRO_CONFIG, config.gyro_range.register()),
            (ACCEL_CONFIG, config.accel_range.register()),
            (ACCEL_CONFIG2, config.dlpf.register()),
        ];
        for (register, value) in settings {
            spi_write_register(&mut bus, register, value)?;
        }
        for (register, wrote) in
            [(GYRO_CONFIG, config.gyro_range.register()), (ACCEL_CONFIG, config.accel_range.register())]
        {
            let read = read_register(&mut bus, register)?;
            if read != wrote {
                return Err(Mpu9250Error::ReadBack { path: bus.path().to_path_buf(), register, wrote, read });
            }
        }
        let mut imu = Mpu9250 { bus, config, mag_adjustment: None };
        if imu.config.magnetometer {
            imu.mag_adjustment = Some(imu.start_magnetometer(sleep)?);
        }
        Ok(imu)
    }

    /// The device node.
    pub fn path(&self) -> &Path {
        self.bus.path()
    }

    /// The AK8963's sensitivity adjustment, when it is in use.
    pub fn mag_adjustment(&self) -> Option<[f64; 3]> {
        self.mag_adjustment
    }

    /// One burst read in raw counts.
    pub fn read_raw(&mut self) -> Result<RawImu, Mpu9250Error> {
        let mut bytes = [0u8; BURST_LEN];
        spi_read_registers(&mut self.bus, ACCEL_XOUT_H, &mut bytes)?;
        Ok(RawImu::parse(&bytes, self.mag_adjustment.is_some()))
    }

    /// One burst read converted to SI units in body FRD, stamped `time`.
    pub fn read(&mut self, time: Time) -> Result<ImuReading, Mpu9250Error> {
        let raw = self.read_raw()?;
        let c = &self.config;
        Ok(ImuReading::from_raw(
            &raw,
            time,
            c.gyro_range,
            c.accel_range,
            &c.axes,
            self.mag_adjustment.unwrap_or([1.0; 3]),
        ))
    }

    fn start_magnetometer(&mut self, sleep: &mut impl FnMut(Duration)) -> Result<[f64; 3], Mpu9250Error> {
        spi_write_register(&mut self.bus, USER_CTRL, I2C_MST_EN | I2C_IF_DIS)?;
        spi_write_register(&mut self.bus, I2C_MST_CTRL, I2C_MST_400KHZ)?;
        self.mag_write(ak8963::CNTL2, ak8963::SRST, sleep)?;
        let mut wia = [0u8; 1];
        self.mag_read(ak8963::WIA, &mut wia, sleep)?;
        if wia[0] != ak8963::WIA_VALUE {
            return Err(Mpu9250Error::MagIdentity { path: self.bus.path().to_path_buf(), found: wia[0] });
        }
        self.mag_write(ak8963::CNTL1, ak8963::MODE_POWER_DOWN, sleep)?;
        self.mag_write(ak8963::CNTL1, ak8963::MODE_FUSE_ROM, sleep)?;
        let mut asa = [0u8; 3];
        self.mag_read(ak8963::ASAX, &mut asa, sleep)?;
        self.mag_write(ak8963::CNTL1, ak8963::MODE_POWER_DOWN, sleep)?;
        self.mag_write(ak8963::CNTL1, ak8963::MODE_CONTINUOUS_100HZ_16BIT, sleep)?;
        self.slave0(ak8963::ADDRESS | SLV_READ, ak8963::ST1, ak8963::READ_LEN as u8)?;
        Ok(ak8963::sensitivity_adjustment(asa))
    }

    fn slave0(&mut self, address: u8, register: u8, len: u8) -> Result<(), Mpu9250Error> {
        spi_write_register(&mut self.bus, I2C_SLV0_ADDR, address)?;
        spi_write_register(&mut self.bus, I2C_SLV0_REG, register)?;
        spi_write_register(&mut self.bus, I2C_SLV0_CTRL, SLV_EN | len)?;
        Ok(())
    }

    fn mag_write(
        &mut self,
        register: u8,
        value: u8,
        sleep: &mut impl FnMut(Duration),
    ) -> Result<(), Mpu9250Error> {
        spi_write_register(&mut self.bus, I2C_SLV0_DO, value)?;
        self.slave0(ak8963::ADDRESS, register, 1)?;
        sleep(SLAVE_TIME);
        Ok(())
    }

    fn mag_read(
        &mut self,
        register: u8,
        out: &mut [u8],
        sleep: &mut impl FnMut(Duration),
    ) -> Result<(), Mpu9250Error> {
        self.slave0(ak8963::ADDRESS | SLV_READ, register, out.len() as u8)?;
        sleep(SLAVE_TIME);
        spi_read_registers(&mut self.bus, EXT_SENS_DATA_00, out)?;
        Ok(())
    }
}

fn read_register(bus: &mut impl SpiBus, register: u8) -> Result<u8, BusError> {
    let mut value = [0u8; 1];
    spi_read_registers(bus, register, &mut value)?;
    Ok(value[0])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mpu9250::fake::FakeMpu9250;
    use kestrel_proto::units::GRAVITY_M_S2;

    #[test]
    fn configures_ranges_filter_and_magnetometer() {
        let mut fake = FakeMpu9250::new(0x71);
        fake.set_fuse_rom([176, 128, 0]);
        fake.set_motion([0, 0, 2048], 0, [164, 0, 0]);
        fake.set_mag([200, 0, 0], false);
        let mut imu = Mpu9250::new(fake, Mpu9250Config::default(), &mut |_| {}).expect("init");
        assert_eq!(imu.mag_adjustment(), Some([1.1875, 1.0, 0.5]));
        let r = imu.read(Time::from_micros(5)).expect("read");
        assert!((r.accel_frd_m_s2[2] + GRAVITY_M_S2).abs() < 1e-12);
        assert!((r.gyro_frd_rad_s[0] - 10f64.to_radians()).abs() < 1e-12);
        // 200 LSB × 1.1875 × 0.0015 G on mag X = accel Y = body left.
        let mag = r.mag_frd_gauss.expect("mag");
        assert!((mag[1] + 200.0 * 1.1875 * 0.0015).abs() < 1e-12, "{mag:?}");
        let bus = imu.bus;
        assert_eq!(bus.register(GYRO_CONFIG), 0x18);
        assert_eq!(bus.register(ACCEL_CONFIG), 0x18);
        assert_eq!((bus.register(CONFIG), bus.register(ACCEL_CONFIG2)), (2, 2));
        assert_eq!(bus.register(SMPLRT_DIV), 0);
        assert_eq!(bus.mag_mode(), ak8963::MODE_CONTINUOUS_100HZ_16BIT);
        assert_eq!(bus.writes().first(), Some(&(PWR_MGMT_1, H_RESET)));
    }

    #[test]
    fn the_mpu9255_identity_is_accepted_without_magnetometer() {
        let config = Mpu9250Config { magnetometer: false, ..Mpu9250Config::default() };
        let mut imu = Mpu9250::new(FakeMpu9250::new(0x73), config, &mut |_| {}).expect("init");
        assert_eq!(imu.read(Time::ZERO).expect("read").mag_frd_gauss, None);
    }

    #[test]
    fn an_empty_bus_fails_the_identity_check_naming_the_device() {
        let err =
            Mpu9250::new(FakeMpu9250::absent(), Mpu9250Config::default(), &mut |_| {}).err().expect("no IMU");
        assert!(matches!(err, Mpu9250Error::Identity { found: 0x00, .. }));
        let text = err.to_string();
        assert!(text.contains("/dev/spidev-fake") && text.contains("0x71"), "{text}");
    }

    #[test]
    fn a_missing_magnetometer_is_reported() {
        let mut fake = FakeMpu9250::new(0x71);
        fake.remove_magnetometer();
        let err = Mpu9250::new(fake, Mpu9250Config::default(), &mut |_| {}).err().expect("no AK8963");
        assert!(matches!(err, Mpu9250Error::MagIdentity { found: 0x00, .. }), "{err}");
    }

    #[test]
    fn a_register_that_does_not_stick_is_reported() {
        let mut fake = FakeMpu9250::new(0x71);
        fake.stick_register(ACCEL_CONFIG, 0x00);
        let err = Mpu9250::new(fake, Mpu9250Config::default(), &mut |_| {}).err().expect("read-back");
        assert!(matches!(
            err,
            Mpu9250Error::ReadBack { register: ACCEL_CONFIG, wrote: 0x18, read: 0x00, .. }
        ));
    }

    #[test]
    fn a_bad_axis_map_is_rejected_before_touching_the_bus() {
        let config =
            Mpu9250Config { axes: AxisMap { axis: [0, 0, 1], sign: [1.0; 3] }, ..Mpu9250Config::default() };
        let fake = FakeMpu9250::new(0x71);
        assert!(matches!(Mpu9250::new(fake, config, &mut |_| {}), Err(Mpu9250Error::AxisMap(_))));
    }
}
