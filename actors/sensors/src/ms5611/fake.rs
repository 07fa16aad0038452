//! An in-memory MS5611 answering the I2C command protocol, for tests and benches without the
//! chip.

use std::path::Path;

use crate::bus::{BusError, I2cBus};
use crate::ms5611::driver::{CMD_ADC_READ, CMD_CONVERT_D1, CMD_CONVERT_D2, CMD_PROM_READ, CMD_RESET};

/// What the next read returns.
#[derive(Clone, Copy, Debug)]
enum Pointer {
    None,
    Prom(usize),
    Adc,
}

/// A fake MS5611 on `/dev/i2c-fake` with a fixed PROM and fixed D1/D2 readings.
#[derive(Clone, Debug)]
pub struct FakeMs5611 {
    prom: [u16; 8],
    d1: u32,
    d2: u32,
    present: bool,
    converts: bool,
    /// The result the ADC holds: set by a conversion, cleared by reading it.
    adc: u32,
    pointer: Pointer,
}

impl FakeMs5611 {
    /// A chip whose PROM holds `prom` and whose conversions return `d1` and `d2`.
    pub fn new(prom: [u16; 8], d1: u32, d2: u32) -> FakeMs5611 {
        FakeMs5611 { prom, d1, d2, present: true, converts: true, adc: 0, pointer: Pointer::None }
    }

    /// No chip on the bus: every transfer fails with ENXIO, as `i2c-dev` does on a NACK.
    pub fn absent() -> FakeMs5611 {
        FakeMs5611 { present: false, ..FakeMs5611::new([0; 8], 0, 0) }
    }

    /// Convert commands are ignored, so ADC reads return 0.
    pub fn skip_conversions(&mut self) {
        self.converts = false;
    }

    /// Sets the raw readings of later conversions.
    pub fn set_raw(&mut self, d1: u32, d2: u32) {
        self.d1 = d1;
        self.d2 = d2;
    }

    fn check_present(&self) -> Result<(), BusError> {
        if self.present {
            Ok(())
        } else {
            Err(BusError::new(self.path(), std::io::Error::from_raw_os_error(6)))
        }
    }
}

impl I2cBus for FakeMs5611 {
    fn path(&self) -> &Path {
        Path::new("/dev/i2c-fake")
    }

    fn write(&mut self, bytes: &[u8]) -> Result<(), BusError> {
        self.check_present()?;
        let Some(&command) = bytes.first() else { return Ok(()) };
        match command {
            CMD_RESET => self.adc = 0,
            CMD_ADC_READ => self.pointer = Pointer::Adc,
            c if (CMD_PROM_READ..=CMD_PROM_READ + 14).contains(&c) => {
                self.pointer = Pointer::Prom(usize::from((c - CMD_PROM_READ) / 2));
            }
            c if self.converts && (CMD_CONVERT_D1..=CMD_CONVERT_D1 + 8).contains(&c) => self.adc = self.d1,
            c if self.converts && (CMD_CONVERT_D2..=CMD_CONVERT_D2 + 8).contains(&c) => self.adc = self.d2,
            _ => {}
        }
        Ok(())
    }

    fn read(&mut self, buf: &mut [u8]) -> Result<(), BusError> {
        self.check_present()?;
        let bytes: Vec<u8> = match self.pointer {
            Pointer::Prom(n) => self.prom[n].to_be_bytes().to_vec(),
            Pointer::Adc => std::mem::take(&mut self.adc).to_be_bytes()[1..].to_vec(),
            Pointer::None => Vec::new(),
        };
        for (i, b) in buf.iter_mut().enumerate() {
            *b = bytes.get(i).copied().unwrap_or(0xFF);
        }
        Ok(())
    }
}
