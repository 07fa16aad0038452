//! The MS5611 command protocol over I2C (datasheet "Commands" and "I2C interface"): reset,
//! PROM read, D1/D2 conversion at a chosen oversampling ratio, ADC read.

use std::path::{Path, PathBuf};
use std::time::Duration;

use crate::bus::{BusError, I2cBus};
use crate::ms5611::compensation::{Compensated, compensate};
use crate::ms5611::prom::{Prom, PromError};

/// Command: reset; the PROM reloads within 2.8 ms.
pub const CMD_RESET: u8 = 0x1E;
/// Command: read the 24-bit ADC result of the last conversion.
pub const CMD_ADC_READ: u8 = 0x00;
/// Command: read PROM word 0; word `n` is at `CMD_PROM_READ + 2n`.
pub const CMD_PROM_READ: u8 = 0xA0;
/// Command: convert D1 (pressure) at OSR 256; add [`Oversampling::command_offset`].
pub const CMD_CONVERT_D1: u8 = 0x40;
/// Command: convert D2 (temperature) at OSR 256; add [`Oversampling::command_offset`].
pub const CMD_CONVERT_D2: u8 = 0x50;
/// Time the PROM needs to reload after a reset (datasheet: 2.8 ms, with margin).
pub const RESET_TIME: Duration = Duration::from_millis(3);

/// What a conversion measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Conversion {
    /// D1.
    Pressure,
    /// D2.
    Temperature,
}

/// Oversampling ratio of a conversion: more is less noisy and slower.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Oversampling {
    Osr256,
    Osr512,
    Osr1024,
    Osr2048,
    Osr4096,
}

impl Oversampling {
    /// What to add to a convert command.
    pub fn command_offset(self) -> u8 {
        match self {
            Oversampling::Osr256 => 0x0,
            Oversampling::Osr512 => 0x2,
            Oversampling::Osr1024 => 0x4,
            Oversampling::Osr2048 => 0x6,
            Oversampling::Osr4096 => 0x8,
        }
    }

    /// Maximum conversion time (datasheet "Operating characteristics": 0.60, 1.17, 2.28, 4.54,
    /// 9.04 ms).
    pub fn conversion_time(self) -> Duration {
        Duration::from_micros(match self {
            Oversampling::Osr256 => 600,
            Oversampling::Osr512 => 1170,
            Oversampling::Osr1024 => 2280,
            Oversampling::Osr2048 => 4540,
            Oversampling::Osr4096 => 9040,
        })
    }
}

/// Why the MS5611 could not be used.
#[derive(Debug, thiserror::Error)]
pub enum Ms5611Error {
    /// The bus transfer failed (device missing, NACK, permissions).
    #[error("MS5611 bus transfer failed: {0}")]
    Bus(#[from] BusError),
    /// The calibration PROM did not check out.
    #[error("{}: MS5611 PROM rejected: {source}", path.display())]
    Prom {
        path: PathBuf,
        #[source]
        source: PromError,
    },
    /// An ADC read returned 0, which the chip does when no conversion was finished.
    #[error("{}: MS5611 returned ADC value 0 (conversion not finished)", path.display())]
    NoConversion { path: PathBuf },
}

/// An MS5611 with a checked PROM.
pub struct Ms5611<B> {
    bus: B,
    prom: Prom,
    osr: Oversampling,
}

impl<B: I2cBus> Ms5611<B> {
    /// Resets the chip, waits for the PROM to reload (through `sleep`) and reads and checks it.
    pub fn new(
        mut bus: B,
        osr: Oversampling,
        sleep: &mut impl FnMut(Duration),
    ) -> Result<Ms5611<B>, Ms5611Error> {
        bus.write(&[CMD_RESET])?;
        sleep(RESET_TIME);
        let mut words = [0u16; 8];
        for (n, word) in words.iter_mut().enumerate() {
            bus.write(&[CMD_PROM_READ + 2 * n as u8])?;
            let mut buf = [0u8; 2];
            bus.read(&mut buf)?;
            *word = u16::from_be_bytes(buf);
        }
        let prom = Prom::new(words)
            .map_err(|source| Ms5611Error::Prom { path: bus.path().to_path_buf(), source })?;
        Ok(Ms5611 { bus, prom, osr })
    }

    /// The checked calibration.
    pub fn prom(&self) -> &Prom {
        &self.prom
    }

    /// The device node.
    pub fn path(&self) -> &Path {
        self.bus.path()
    }

    /// Converts D2 then D1, waiting out each conversion through `sleep`, and compensates.
    pub fn measure(&mut self, sleep: &mut impl FnMut(Duration)) -> Result<Compensated, Ms5611Error> {
        self.start(Conversion::Temperature)?;
        sleep(self.osr.conversion_time());
        let d2 = self.read_result()?;
        self.start(Conversion::Pressure)?;
        sleep(self.osr.conversion_time());
        let d1 = self.read_result()?;
        Ok(compensate(&self.prom, d1, d2))
    }

    /// Starts a conversion; its result can be read [`Oversampling::conversion_time`] later.
    pub fn start(&mut self, conversion: Conversion) -> Result<(), Ms5611Error> {
        let base = match conversion {
            Conversion::Pressure => CMD_CONVERT_D1,
            Conversion::Temperature => CMD_CONVERT_D2,
        };
        self.bus.write(&[base + self.osr.command_offset()])?;
        Ok(())
    }

    /// Reads the finished conversion's 24-bit result (D1 or D2).
    pub fn read_result(&mut self) -> Result<u32, Ms5611Error> {
        self.bus.write(&[CMD_ADC_READ])?;
        let mut buf = [0u8; 3];
        self.bus.read(&mut buf)?;
        match u32::from_be_bytes([0, buf[0], buf[1], buf[2]]) {
            0 => Err(Ms5611Error::NoConversion { path: self.bus.path().to_path_buf() }),
            raw => Ok(raw),
        }
    }

    /// The oversampling ratio in use.
    pub fn oversampling(&self) -> Oversampling {
        self.osr
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ms5611::fake::FakeMs5611;
    use crate::ms5611::prom::tests::datasheet_prom_words;

    #[test]
    fn reads_the_prom_and_measures_the_datasheet_example() {
        let fake = FakeMs5611::new(datasheet_prom_words(), 9_085_466, 8_569_150);
        let mut slept = Vec::new();
        let mut sleep = |d| slept.push(d);
        let mut baro = Ms5611::new(fake, Oversampling::Osr4096, &mut sleep).expect("init");
        let reading = baro.measure(&mut sleep).expect("measure");
        assert_eq!(reading, Compensated { temperature_centi_c: 2007, pressure_pa: 100_009 });
        assert_eq!(slept, [RESET_TIME, Duration::from_micros(9040), Duration::from_micros(9040)]);
    }

    #[test]
    fn a_corrupt_prom_is_an_error_naming_the_device() {
        let mut words = datasheet_prom_words();
        words[3] ^= 0x0100;
        let fake = FakeMs5611::new(words, 9_085_466, 8_569_150);
        let err = Ms5611::new(fake, Oversampling::Osr4096, &mut |_| {}).err().expect("rejected");
        assert!(matches!(err, Ms5611Error::Prom { source: PromError::Crc { .. }, .. }));
        assert!(err.to_string().contains("/dev/i2c-fake"), "{err}");
    }

    #[test]
    fn a_missing_chip_is_a_bus_error_naming_the_device() {
        let fake = FakeMs5611::absent();
        let err = Ms5611::new(fake, Oversampling::Osr4096, &mut |_| {}).err().expect("absent");
        assert!(matches!(err, Ms5611Error::Bus(_)));
        assert!(err.to_string().contains("/dev/i2c-fake"), "{err}");
    }

    #[test]
    fn reading_before_the_conversion_is_reported() {
        let mut fake = FakeMs5611::new(datasheet_prom_words(), 9_085_466, 8_569_150);
        fake.skip_conversions();
        let mut baro = Ms5611::new(fake, Oversampling::Osr256, &mut |_| {}).expect("init");
        assert!(matches!(baro.measure(&mut |_| {}), Err(Ms5611Error::NoConversion { .. })));
    }
}
