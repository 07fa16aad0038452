//! A register-level MPU-9250 with an AK8963 behind its I2C master, answering the SPI protocol
//! (bit 7 of the first byte = read, then consecutive registers), for tests and benches
//! without the board.

use std::path::Path;

use crate::ak8963;
use crate::bus::{BusError, SpiBus};
use crate::mpu9250::registers::*;

/// A fake IMU on `/dev/spidev-fake`.
#[derive(Clone, Debug)]
pub struct FakeMpu9250 {
    registers: [u8; 128],
    identity: u8,
    /// When false, MISO floats low: every read returns 0, writes vanish.
    present: bool,
    mag_present: bool,
    mag: [u8; 0x13],
    fuse_rom: [u8; 3],
    /// A register stuck at a value whatever is written.
    stuck: Option<(u8, u8)>,
    writes: Vec<(u8, u8)>,
}

impl FakeMpu9250 {
    /// A chip answering WHO_AM_I with `identity`, with an AK8963.
    pub fn new(identity: u8) -> FakeMpu9250 {
        let mut fake = FakeMpu9250 {
            registers: [0; 128],
            identity,
            present: true,
            mag_present: true,
            mag: [0; 0x13],
            fuse_rom: [128; 3],
            stuck: None,
            writes: Vec::new(),
        };
        fake.reset();
        fake
    }

    /// Nothing on the chip select.
    pub fn absent() -> FakeMpu9250 {
        FakeMpu9250 { present: false, ..FakeMpu9250::new(0x71) }
    }

    /// The AK8963 does not acknowledge.
    pub fn remove_magnetometer(&mut self) {
        self.mag_present = false;
    }

    /// The AK8963's fuse ROM sensitivity values.
    pub fn set_fuse_rom(&mut self, asa: [u8; 3]) {
        self.fuse_rom = asa;
    }

    /// Makes `register` read `value` whatever is written to it.
    pub fn stick_register(&mut self, register: u8, value: u8) {
        self.stuck = Some((register, value));
    }

    /// The next sample's raw accelerometer, temperature and gyro counts (chip axes).
    pub fn set_motion(&mut self, accel: [i16; 3], temperature: i16, gyro: [i16; 3]) {
        let words = [accel[0], accel[1], accel[2], temperature, gyro[0], gyro[1], gyro[2]];
        for (i, w) in words.iter().enumerate() {
            let at = usize::from(ACCEL_XOUT_H) + 2 * i;
            self.registers[at..at + 2].copy_from_slice(&w.to_be_bytes());
        }
    }

    /// The AK8963's next measurement (its own axes), flagged new, with or without overflow.
    pub fn set_mag(&mut self, raw: [i16; 3], overflow: bool) {
        self.mag[usize::from(ak8963::ST1)] = 0x01;
        for (i, v) in raw.iter().enumerate() {
            let at = usize::from(ak8963::HXL) + 2 * i;
            self.mag[at..at + 2].copy_from_slice(&v.to_le_bytes());
        }
        self.mag[usize::from(ak8963::ST2)] = 0x10 | if overflow { ak8963::HOFL } else { 0 };
    }

    /// A register's current value.
    pub fn register(&self, register: u8) -> u8 {
        self.read_register(register)
    }

    /// The AK8963's `CNTL1` mode.
    pub fn mag_mode(&self) -> u8 {
        self.mag[usize::from(ak8963::CNTL1)]
    }

    /// Every register write so far, in order.
    pub fn writes(&self) -> &[(u8, u8)] {
        &self.writes
    }

    fn reset(&mut self) {
        let motion = self.registers[usize::from(ACCEL_XOUT_H)..usize::from(EXT_SENS_DATA_00)].to_vec();
        self.registers = [0; 128];
        self.registers[usize::from(PWR_MGMT_1)] = 0x01;
        self.registers[usize::from(WHO_AM_I)] = self.identity;
        self.registers[usize::from(ACCEL_XOUT_H)..usize::from(EXT_SENS_DATA_00)].copy_from_slice(&motion);
    }

    fn read_register(&self, register: u8) -> u8 {
        match self.stuck {
            Some((r, v)) if r == register => v,
            _ => self.registers[usize::from(register & 0x7F)],
        }
    }

    fn write_register(&mut self, register: u8, value: u8) {
        self.writes.push((register, value));
        match register {
            PWR_MGMT_1 if value & H_RESET != 0 => self.reset(),
            WHO_AM_I => {}
            I2C_SLV0_CTRL => {
                self.registers[usize::from(register)] = value;
                self.run_slave0();
            }
            _ => self.registers[usize::from(register & 0x7F)] = value,
        }
    }

    /// One transaction of I2C slave 0, as the master runs after every sample.
    fn run_slave0(&mut self) {
        let ctrl = self.registers[usize::from(I2C_SLV0_CTRL)];
        let master_on = self.registers[usize::from(USER_CTRL)] & I2C_MST_EN != 0;
        if ctrl & SLV_EN == 0 || !master_on {
            return;
        }
        let address = self.registers[usize::from(I2C_SLV0_ADDR)];
        let register = usize::from(self.registers[usize::from(I2C_SLV0_REG)]);
        let len = usize::from(ctrl & 0x0F);
        let acknowledged = self.mag_present && address & 0x7F == ak8963::ADDRESS;
        if address & SLV_READ != 0 {
            for i in 0..len {
                let value = if acknowledged { self.mag_register(register + i) } else { 0 };
                self.registers[usize::from(EXT_SENS_DATA_00) + i] = value;
            }
        } else if acknowledged {
            self.mag_write(register, self.registers[usize::from(I2C_SLV0_DO)]);
        }
    }

    fn mag_register(&self, register: usize) -> u8 {
        let asa = usize::from(ak8963::ASAX)..usize::from(ak8963::ASAX) + 3;
        match register {
            r if r == usize::from(ak8963::WIA) => ak8963::WIA_VALUE,
            r if asa.contains(&r) => {
                if self.mag_mode() == ak8963::MODE_FUSE_ROM {
                    self.fuse_rom[r - asa.start]
                } else {
                    0
                }
            }
            r => self.mag.get(r).copied().unwrap_or(0),
        }
    }

    fn mag_write(&mut self, register: usize, value: u8) {
        if register == usize::from(ak8963::CNTL2) && value & ak8963::SRST != 0 {
            self.mag[usize::from(ak8963::CNTL1)] = ak8963::MODE_POWER_DOWN;
        } else if let Some(r) = self.mag.get_mut(register) {
            *r = value;
        }
    }
}

impl SpiBus for FakeMpu9250 {
    fn path(&self) -> &Path {
        Path::new("/dev/spidev-fake")
    }

    fn transfer(&mut self, buf: &mut [u8]) -> Result<(), BusError> {
        if !self.present {
            buf.fill(0);
            return Ok(());
        }
        let Some((first, rest)) = buf.split_first_mut() else { return Ok(()) };
        let first = *first;
        let start = first & 0x7F;
        if first & 0x80 != 0 {
            let touches_ext = (usize::from(start)..usize::from(start) + rest.len())
                .contains(&usize::from(EXT_SENS_DATA_00));
            if touches_ext && self.registers[usize::from(I2C_SLV0_ADDR)] & SLV_READ != 0 {
                self.run_slave0();
            }
            for (i, b) in rest.iter_mut().enumerate() {
                *b = self.read_register(start.wrapping_add(i as u8) & 0x7F);
            }
        } else {
            for (i, &b) in rest.iter().enumerate() {
                self.write_register(start.wrapping_add(i as u8) & 0x7F, b);
            }
        }
        Ok(())
    }
}
