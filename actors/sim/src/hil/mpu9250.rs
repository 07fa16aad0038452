//! The MPU-9250's SPI register protocol (InvenSense RM-MPU-9250A-00 rev 1.6, PS-MPU-9250A-01)
//! with the AK8963 magnetometer behind its auxiliary I2C master (AKM MS1356-E-02): a register
//! file the driver configures, WHO_AM_I, and data registers carrying the simulated specific
//! force, angular rate and die temperature at the full-scale ranges the driver wrote, and the
//! field at the AK8963's 16-bit resolution and fuse-ROM adjustment.
//!
//! The simulator holds a [`Mpu9250World`] handle to the chip while the driver owns the chip as
//! its bus. Values are given in the chip's own axes (the simulator maps body FRD through the board's
//! mounting); counts saturate at the ends of the 16-bit range, as the chip's do, so the
//! driver's clipping detection sees them.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};

use kestrel_proto::bus::{BusError, SpiBus};
use kestrel_proto::units::GRAVITY_M_S2;

// Register map (RM §4).
const GYRO_CONFIG: u8 = 0x1B;
const ACCEL_CONFIG: u8 = 0x1C;
const I2C_SLV0_ADDR: u8 = 0x25;
const I2C_SLV0_REG: u8 = 0x26;
const I2C_SLV0_CTRL: u8 = 0x27;
const ACCEL_XOUT_H: u8 = 0x3B;
const EXT_SENS_DATA_00: u8 = 0x49;
const I2C_SLV0_DO: u8 = 0x63;
const PWR_MGMT_1: u8 = 0x6B;
const WHO_AM_I: u8 = 0x75;
/// `PWR_MGMT_1` reset value (RM §4.30) and its `H_RESET` bit.
const PWR_MGMT_1_RESET: u8 = 0x01;
const H_RESET: u8 = 0x80;
/// `I2C_SLV0_CTRL` enable and `I2C_SLV0_ADDR` read bits; byte count in `CTRL` bits 3:0.
const SLV_EN: u8 = 0x80;
const SLV_READ: u8 = 0x80;
/// The MPU-9250's identity (RM §4.32).
pub const MPU9250_WHO_AM_I: u8 = 0x71;

// AK8963 (MS1356-E-02 §8).
const AK_ADDRESS: u8 = 0x0C;
const AK_WIA: u8 = 0x00;
const AK_WIA_VALUE: u8 = 0x48;
const AK_ST1: u8 = 0x02;
const AK_HXL: u8 = 0x03;
const AK_ST2: u8 = 0x09;
const AK_CNTL1: u8 = 0x0A;
const AK_CNTL2: u8 = 0x0B;
const AK_ASAX: u8 = 0x10;
/// `ST1.DRDY`, `ST2.BITM` (16-bit output), `CNTL1` fuse-ROM mode, `CNTL2.SRST`.
const AK_DRDY: u8 = 0x01;
const AK_BITM: u8 = 0x10;
const AK_MODE_FUSE_ROM: u8 = 0x0F;
const AK_SRST: u8 = 0x01;
/// 16-bit resolution: 0.15 µT = 0.0015 gauss per count (§5.3).
const AK_GAUSS_PER_LSB: f64 = 0.0015;

/// Gyro sensitivity per `GYRO_FS_SEL` (LSB per °/s, PS §3.1) and accelerometer sensitivity per
/// `ACCEL_FS_SEL` (LSB per g, PS §3.2).
const GYRO_LSB_PER_DPS: [f64; 4] = [131.0, 65.5, 32.8, 16.4];
const ACCEL_LSB_PER_G: [f64; 4] = [16384.0, 8192.0, 4096.0, 2048.0];
/// Die temperature: 333.87 LSB/°C, 0 LSB at 21 °C (PS §3.4.2).
const TEMP_LSB_PER_C: f64 = 333.87;
const TEMP_OFFSET_C: f64 = 21.0;

/// An MPU-9250 at `path` reading the simulated motion and field.
#[derive(Debug)]
pub struct Mpu9250Emulator {
    path: PathBuf,
    who_am_i: u8,
    registers: [u8; 128],
    ak: Ak8963,
    world: Mpu9250World,
}

/// What the chip senses, set by the simulator.
#[derive(Clone, Debug, Default)]
pub struct Mpu9250World(Arc<Mutex<Sensed>>);

#[derive(Clone, Copy, Debug)]
struct Sensed {
    accel_chip_m_s2: [f64; 3],
    gyro_chip_rad_s: [f64; 3],
    temperature_c: f64,
    /// The AK8963's latest measurement in its own axes (counts) and its number.
    field_counts: [i16; 3],
    field_number: u64,
}

impl Default for Sensed {
    /// Level and still at 21 °C, no field measured.
    fn default() -> Sensed {
        Sensed {
            accel_chip_m_s2: [0.0, 0.0, GRAVITY_M_S2],
            gyro_chip_rad_s: [0.0; 3],
            temperature_c: TEMP_OFFSET_C,
            field_counts: [0; 3],
            field_number: 0,
        }
    }
}

/// The magnetometer behind the I2C master.
#[derive(Clone, Debug)]
struct Ak8963 {
    registers: [u8; 0x13],
    asa: [u8; 3],
    /// The number of the last measurement read out (or current at the last reset).
    read_number: u64,
}

impl Mpu9250World {
    fn with<R>(&self, f: impl FnOnce(&mut Sensed) -> R) -> R {
        f(&mut self.0.lock().unwrap_or_else(PoisonError::into_inner))
    }

    /// What the IMU reads now, in chip axes: specific force (m/s²), angular rate (rad/s) and
    /// die temperature (°C).
    pub fn set_motion(&self, accel_chip_m_s2: [f64; 3], gyro_chip_rad_s: [f64; 3], temperature_c: f64) {
        self.with(|s| {
            s.accel_chip_m_s2 = accel_chip_m_s2;
            s.gyro_chip_rad_s = gyro_chip_rad_s;
            s.temperature_c = temperature_c;
        });
    }

    /// A new magnetometer measurement, the field in the accelerometer's chip axes (gauss), for
    /// a part whose fuse ROM holds `asa`.
    pub fn set_field(&self, field_chip_gauss: [f64; 3], asa: [u8; 3]) {
        // AK8963 axes: X_mag = Y_accel, Y_mag = X_accel, Z_mag = −Z_accel (PS §9.1).
        let mag = [field_chip_gauss[1], field_chip_gauss[0], -field_chip_gauss[2]];
        let counts: [i16; 3] = std::array::from_fn(|i| {
            let adjustment = (f64::from(asa[i]) - 128.0) * 0.5 / 128.0 + 1.0;
            saturate(mag[i] / (AK_GAUSS_PER_LSB * adjustment))
        });
        self.with(|s| {
            s.field_counts = counts;
            s.field_number += 1;
        });
    }
}

impl Mpu9250Emulator {
    /// A chip at `path` answering WHO_AM_I with `who_am_i` (0x71 for an MPU-9250; anything else
    /// is a wrong part), with fuse-ROM adjustment values `asa` in its AK8963, level and still.
    pub fn new(path: &Path, who_am_i: u8, asa: [u8; 3]) -> Mpu9250Emulator {
        Mpu9250Emulator::with_world(path, who_am_i, asa, Mpu9250World::default())
    }

    /// The same chip sensing through an existing `world` handle (a chip reopened by a
    /// restarted driver, powered up afresh in the same world).
    pub fn with_world(path: &Path, who_am_i: u8, asa: [u8; 3], world: Mpu9250World) -> Mpu9250Emulator {
        let mut chip = Mpu9250Emulator {
            path: path.to_owned(),
            who_am_i,
            registers: [0; 128],
            ak: Ak8963 { registers: [0; 0x13], asa, read_number: 0 },
            world,
        };
        chip.reset();
        chip.ak.reset(0);
        chip
    }

    /// The handle through which the simulator sets what the chip senses.
    pub fn world(&self) -> Mpu9250World {
        self.world.clone()
    }

    /// The AK8963's fuse-ROM values.
    pub fn asa(&self) -> [u8; 3] {
        self.ak.asa
    }

    /// Register `reg`'s value.
    pub fn register(&self, reg: u8) -> u8 {
        self.registers[usize::from(reg & 0x7F)]
    }

    fn reset(&mut self) {
        self.registers = [0; 128];
        self.registers[usize::from(PWR_MGMT_1)] = PWR_MGMT_1_RESET;
        self.registers[usize::from(WHO_AM_I)] = self.who_am_i;
    }

    /// The 14 data registers from the current motion at the configured ranges.
    fn sample(&mut self) {
        let gyro_fs = usize::from((self.register(GYRO_CONFIG) >> 3) & 0x03);
        let accel_fs = usize::from((self.register(ACCEL_CONFIG) >> 3) & 0x03);
        let sensed = self.world.with(|s| *s);
        let accel = sensed.accel_chip_m_s2.map(|a| saturate(a / GRAVITY_M_S2 * ACCEL_LSB_PER_G[accel_fs]));
        let gyro = sensed.gyro_chip_rad_s.map(|w| saturate(w.to_degrees() * GYRO_LSB_PER_DPS[gyro_fs]));
        let temperature = saturate((sensed.temperature_c - TEMP_OFFSET_C) * TEMP_LSB_PER_C);
        let words = [accel[0], accel[1], accel[2], temperature, gyro[0], gyro[1], gyro[2]];
        for (i, word) in words.iter().enumerate() {
            let at = usize::from(ACCEL_XOUT_H) + 2 * i;
            self.registers[at..at + 2].copy_from_slice(&word.to_be_bytes());
        }
        if self.slave0_reads() {
            self.slave0_transfer();
        }
    }

    fn slave0_reads(&self) -> bool {
        self.register(I2C_SLV0_CTRL) & SLV_EN != 0 && self.register(I2C_SLV0_ADDR) & SLV_READ != 0
    }

    /// One slave-0 transaction with the AK8963, as the I2C master runs it after a sample (a
    /// write once, when it is enabled): a read lands in `EXT_SENS_DATA_00..`, a write takes
    /// `SLV0_DO`.
    fn slave0_transfer(&mut self) {
        let address = self.register(I2C_SLV0_ADDR);
        let first = self.register(I2C_SLV0_REG);
        let len = usize::from(self.register(I2C_SLV0_CTRL) & 0x0F);
        if address & 0x7F != AK_ADDRESS {
            // No other slave on the bus: the master reads nothing.
            let at = usize::from(EXT_SENS_DATA_00);
            self.registers[at..at + len].fill(0);
            return;
        }
        let sensed = self.world.with(|s| *s);
        if address & SLV_READ != 0 {
            for i in 0..len {
                let value = self.ak.read(first.wrapping_add(i as u8), &sensed);
                self.registers[usize::from(EXT_SENS_DATA_00) + i] = value;
            }
        } else {
            let value = self.register(I2C_SLV0_DO);
            self.ak.write(first, value, sensed.field_number);
        }
    }

    fn write(&mut self, reg: u8, value: u8) {
        match reg {
            PWR_MGMT_1 if value & H_RESET != 0 => self.reset(),
            // Read-only.
            WHO_AM_I | ACCEL_XOUT_H..=0x60 => {}
            _ => {
                self.registers[usize::from(reg & 0x7F)] = value;
                if reg == I2C_SLV0_CTRL && value & SLV_EN != 0 && !self.slave0_reads() {
                    self.slave0_transfer();
                }
            }
        }
    }
}

impl Ak8963 {
    /// A soft reset: registers cleared, the current measurement counted as old.
    fn reset(&mut self, field_number: u64) {
        self.registers = [0; 0x13];
        self.registers[usize::from(AK_WIA)] = AK_WIA_VALUE;
        self.read_number = field_number;
    }

    fn read(&mut self, reg: u8, sensed: &Sensed) -> u8 {
        let fuse_rom = self.registers[usize::from(AK_CNTL1)] & 0x0F == AK_MODE_FUSE_ROM;
        let measuring = self.registers[usize::from(AK_CNTL1)] & 0x0F != 0 && !fuse_rom;
        let fresh = measuring && sensed.field_number != self.read_number;
        let data = |i: usize| sensed.field_counts[i / 2].to_le_bytes()[i % 2];
        match reg {
            AK_ST1 => u8::from(fresh) * AK_DRDY,
            r if (AK_HXL..AK_ST2).contains(&r) => data(usize::from(r - AK_HXL)),
            // Reading ST2 ends the read: the data are no longer new.
            AK_ST2 => {
                self.read_number = sensed.field_number;
                AK_BITM
            }
            r if (AK_ASAX..AK_ASAX + 3).contains(&r) && fuse_rom => self.asa[usize::from(r - AK_ASAX)],
            r => self.registers.get(usize::from(r)).copied().unwrap_or(0),
        }
    }

    fn write(&mut self, reg: u8, value: u8, field_number: u64) {
        match reg {
            AK_CNTL2 if value & AK_SRST != 0 => self.reset(field_number),
            AK_CNTL1 => self.registers[usize::from(AK_CNTL1)] = value,
            _ => {}
        }
    }
}

impl SpiBus for Mpu9250Emulator {
    fn path(&self) -> &Path {
        &self.path
    }

    fn transfer(&mut self, buf: &mut [u8]) -> Result<(), BusError> {
        let Some((address, data)) = buf.split_first_mut() else { return Ok(()) };
        let address = *address;
        let first = address & 0x7F;
        if address & 0x80 != 0 {
            // A burst from the data registers is a new sample (the I2C master fetches its
            // slave's bytes with it); a read of the slave's bytes alone waits out one fetch.
            if first == ACCEL_XOUT_H {
                self.sample();
            } else if first == EXT_SENS_DATA_00 && self.slave0_reads() {
                self.slave0_transfer();
            }
            for (i, byte) in data.iter_mut().enumerate() {
                *byte = self.register(first.wrapping_add(i as u8));
            }
        } else {
            for (i, &byte) in data.iter().enumerate() {
                self.write(first.wrapping_add(i as u8) & 0x7F, byte);
            }
        }
        Ok(())
    }
}

/// A count rounded to the nearest and held at the ends of the signed 16-bit range.
fn saturate(counts: f64) -> i16 {
    counts.round().clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16
}
