//! The MS5611 barometer's I2C command protocol (MS5611-01BA03 datasheet): reset, PROM read,
//! D1/D2 conversion and ADC read, with a PROM whose CRC-4 is valid (application note AN520)
//! and raw conversions chosen so that the datasheet's first- and second-order compensation
//! turns them back into the simulated pressure and temperature.
//!
//! The inverse is worked from the datasheet's formulas: the temperature fixes dT (a quadratic
//! below 20 °C, where the second-order term T2 = dT²/2³¹ applies), dT fixes OFF and SENS, and
//! the pressure then fixes D1. Each target is the middle of its 0.01 °C / 1 Pa step, so the
//! driver's rounding towards −∞ lands on the simulated value.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};

use kestrel_proto::bus::{BusError, I2cBus};

/// Commands (datasheet "Commands").
const CMD_RESET: u8 = 0x1E;
const CMD_ADC_READ: u8 = 0x00;
const CMD_PROM_READ: u8 = 0xA0;
const CMD_CONVERT_D1: u8 = 0x40;
const CMD_CONVERT_D2: u8 = 0x50;
/// The four oversampling ratios add 0, 2, 4, 6 or 8 to a convert command.
const OSR_OFFSETS: u8 = 8;
/// The ADC's range: 24 bits.
const ADC_MAX: i64 = (1 << 24) - 1;

/// The datasheet's typical calibration coefficients C1..C6 ("Pressure and temperature
/// calculation", typical values column).
pub const DATASHEET_COEFFICIENTS: [u16; 6] = [40127, 36924, 23317, 23282, 33464, 28312];

/// What the next read returns.
#[derive(Clone, Copy, Debug)]
enum Pointer {
    None,
    Prom(usize),
    Adc,
}

/// What the chip senses, set by the simulator while the driver owns the chip as its bus:
/// static pressure (Pa) and the sensor's temperature (°C).
#[derive(Clone, Debug)]
pub struct Ms5611World(Arc<Mutex<(f64, f64)>>);

impl Default for Ms5611World {
    /// ISA sea level: 101 325 Pa at 15 °C.
    fn default() -> Ms5611World {
        Ms5611World(Arc::new(Mutex::new((101_325.0, 15.0))))
    }
}

impl Ms5611World {
    /// What the world reads now: static pressure (Pa) and the sensor's temperature (°C).
    pub fn set_reading(&self, pressure_pa: f64, temperature_c: f64) {
        *self.0.lock().unwrap_or_else(PoisonError::into_inner) = (pressure_pa, temperature_c);
    }

    fn reading(&self) -> (f64, f64) {
        *self.0.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// An MS5611 at `path` reading the simulated pressure and temperature.
#[derive(Clone, Debug)]
pub struct Ms5611Emulator {
    path: PathBuf,
    prom: [u16; 8],
    world: Ms5611World,
    /// The conversion result the ADC holds: set by a convert command, cleared by reading it
    /// (a read without a conversion returns 0, as the chip does).
    adc: u32,
    pointer: Pointer,
}

impl Ms5611Emulator {
    /// A chip at `path` with calibration coefficients `c` (C1..C6), reading ISA sea level.
    pub fn new(path: &Path, c: [u16; 6]) -> Ms5611Emulator {
        let mut prom = [0u16; 8];
        prom[1..7].copy_from_slice(&c);
        prom[7] = 0x4500;
        prom[7] |= u16::from(crc4(&prom));
        Ms5611Emulator {
            path: path.to_owned(),
            prom,
            world: Ms5611World::default(),
            adc: 0,
            pointer: Pointer::None,
        }
    }

    /// What the world reads now (the same as through [`Ms5611Emulator::world`]).
    pub fn set_reading(&mut self, pressure_pa: f64, temperature_c: f64) {
        self.world.set_reading(pressure_pa, temperature_c);
    }

    /// The handle through which the simulator sets what the chip senses.
    pub fn world(&self) -> Ms5611World {
        self.world.clone()
    }

    /// The PROM image (words 0..7).
    pub fn prom(&self) -> [u16; 8] {
        self.prom
    }

    /// The raw conversions (D1, D2) the chip returns for the current reading.
    pub fn raw(&self) -> (u32, u32) {
        let (pressure_pa, temperature_c) = self.world.reading();
        let c = |i: usize| self.prom[i] as f64;
        // The middle of the driver's 0.01 °C step, then dT from TEMP = 2000 + dT·C6/2²³ − T2.
        let temp = (temperature_c * 100.0).floor() + 0.5;
        let k = c(6) / 2f64.powi(23);
        let dt = if temp >= 2000.0 {
            (temp - 2000.0) / k
        } else {
            // dT²/2³¹ − k·dT + (temp − 2000) = 0, the root near the first-order dT.
            let a = 1.0 / 2f64.powi(31);
            (k - (k * k - 4.0 * a * (temp - 2000.0)).sqrt()) / (2.0 * a)
        };
        let d2 = (dt + c(5) * 256.0).round().clamp(0.0, ADC_MAX as f64) as i64;
        let dt = d2 - (i64::from(self.prom[5]) << 8);
        // OFF and SENS at that dT, with the second-order terms where they apply.
        let first_temp = 2000 + ((dt * i64::from(self.prom[6])) >> 23);
        let mut off = (i64::from(self.prom[2]) << 16) + ((i64::from(self.prom[4]) * dt) >> 7);
        let mut sens = (i64::from(self.prom[1]) << 15) + ((i64::from(self.prom[3]) * dt) >> 8);
        if first_temp < 2000 {
            let cold = (first_temp - 2000) * (first_temp - 2000);
            let (mut off2, mut sens2) = ((5 * cold) >> 1, (5 * cold) >> 2);
            if first_temp < -1500 {
                let very_cold = (first_temp + 1500) * (first_temp + 1500);
                off2 += 7 * very_cold;
                sens2 += (11 * very_cold) >> 1;
            }
            off -= off2;
            sens -= sens2;
        }
        // P = (D1·SENS/2²¹ − OFF)/2¹⁵ at the middle of the 1 Pa step.
        let p = pressure_pa.floor() + 0.5;
        let d1 = ((p * 2f64.powi(15) + off as f64) * 2f64.powi(21) / sens.max(1) as f64).round();
        (d1.clamp(0.0, ADC_MAX as f64) as u32, d2 as u32)
    }
}

impl I2cBus for Ms5611Emulator {
    fn path(&self) -> &Path {
        &self.path
    }

    fn write(&mut self, bytes: &[u8]) -> Result<(), BusError> {
        let Some(&command) = bytes.first() else { return Ok(()) };
        match command {
            CMD_RESET => {
                self.adc = 0;
                self.pointer = Pointer::None;
            }
            CMD_ADC_READ => self.pointer = Pointer::Adc,
            c if (CMD_PROM_READ..=CMD_PROM_READ + 14).contains(&c) && c % 2 == 0 => {
                self.pointer = Pointer::Prom(usize::from((c - CMD_PROM_READ) / 2));
            }
            c if (CMD_CONVERT_D1..=CMD_CONVERT_D1 + OSR_OFFSETS).contains(&c) => self.adc = self.raw().0,
            c if (CMD_CONVERT_D2..=CMD_CONVERT_D2 + OSR_OFFSETS).contains(&c) => self.adc = self.raw().1,
            // An unknown command is ignored by the chip.
            _ => {}
        }
        Ok(())
    }

    fn read(&mut self, buf: &mut [u8]) -> Result<(), BusError> {
        let mut bytes = [0xFFu8; 3];
        let n = match self.pointer {
            Pointer::Prom(i) => {
                bytes[..2].copy_from_slice(&self.prom[i].to_be_bytes());
                2
            }
            Pointer::Adc => {
                bytes.copy_from_slice(&std::mem::take(&mut self.adc).to_be_bytes()[1..]);
                3
            }
            Pointer::None => 0,
        };
        for (i, b) in buf.iter_mut().enumerate() {
            *b = if i < n { bytes[i] } else { 0xFF };
        }
        Ok(())
    }
}

/// AN520's CRC-4 over a PROM image (word 7's low byte taken as zero): polynomial 0x3000 on a
/// 16-bit remainder, bytes most significant first.
fn crc4(words: &[u16; 8]) -> u8 {
    let mut prom = *words;
    prom[7] &= 0xFF00;
    let mut rem: u16 = 0;
    for byte in prom.iter().flat_map(|w| w.to_be_bytes()) {
        rem ^= u16::from(byte);
        for _ in 0..8 {
            rem = if rem & 0x8000 != 0 { (rem << 1) ^ 0x3000 } else { rem << 1 };
        }
    }
    ((rem >> 12) & 0x000F) as u8
}
