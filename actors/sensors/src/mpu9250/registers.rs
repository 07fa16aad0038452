//! MPU-9250 register map (InvenSense RM-MPU-9250A-00 rev 1.6, "Register Map and
//! Descriptions") and the bits this driver sets.

/// Sample rate divider: rate = 1 kHz / (1 + SMPLRT_DIV) while the DLPF is on (§4.4).
pub const SMPLRT_DIV: u8 = 0x19;
/// `DLPF_CFG` in bits 2:0 (§4.5).
pub const CONFIG: u8 = 0x1A;
/// `GYRO_FS_SEL` in bits 4:3, `FCHOICE_B` in bits 1:0 (§4.6).
pub const GYRO_CONFIG: u8 = 0x1B;
/// `ACCEL_FS_SEL` in bits 4:3 (§4.7).
pub const ACCEL_CONFIG: u8 = 0x1C;
/// `ACCEL_FCHOICE_B` in bit 3, `A_DLPFCFG` in bits 2:0 (§4.8).
pub const ACCEL_CONFIG2: u8 = 0x1D;
/// I2C master clock and timing (§4.11); 0x0D = 400 kHz.
pub const I2C_MST_CTRL: u8 = 0x24;
/// Slave 0 address, bit 7 set to read (§4.12).
pub const I2C_SLV0_ADDR: u8 = 0x25;
/// Slave 0 first register.
pub const I2C_SLV0_REG: u8 = 0x26;
/// Slave 0 enable (bit 7) and byte count (bits 3:0).
pub const I2C_SLV0_CTRL: u8 = 0x27;
/// First of 14 bytes: accel X/Y/Z, temperature, gyro X/Y/Z, each big-endian i16 (§4.17–4.23).
pub const ACCEL_XOUT_H: u8 = 0x3B;
/// Data the I2C master read from its slaves, right after the gyro registers (§4.24).
pub const EXT_SENS_DATA_00: u8 = 0x49;
/// Byte slave 0 writes (§4.26).
pub const I2C_SLV0_DO: u8 = 0x63;
/// `I2C_MST_EN` (bit 5), `I2C_IF_DIS` (bit 4) (§4.29).
pub const USER_CTRL: u8 = 0x6A;
/// `H_RESET` (bit 7), `CLKSEL` (bits 2:0) (§4.30).
pub const PWR_MGMT_1: u8 = 0x6B;
/// Axis disables; 0 = all on (§4.31).
pub const PWR_MGMT_2: u8 = 0x6C;
/// Identity: 0x71 for MPU-9250, 0x73 for MPU-9255 (§4.32).
pub const WHO_AM_I: u8 = 0x75;

/// `PWR_MGMT_1`: reset every register.
pub const H_RESET: u8 = 0x80;
/// `PWR_MGMT_1`: best available clock (gyro PLL).
pub const CLKSEL_AUTO: u8 = 0x01;
/// `USER_CTRL`: enable the auxiliary I2C master.
pub const I2C_MST_EN: u8 = 0x20;
/// `USER_CTRL`: SPI only (disable the I2C slave interface).
pub const I2C_IF_DIS: u8 = 0x10;
/// `I2C_MST_CTRL`: 400 kHz master clock.
pub const I2C_MST_400KHZ: u8 = 0x0D;
/// `I2C_SLV0_CTRL`: enable.
pub const SLV_EN: u8 = 0x80;
/// `I2C_SLV0_ADDR`: read transfer.
pub const SLV_READ: u8 = 0x80;
/// Identities accepted.
pub const WHO_AM_I_VALUES: [u8; 2] = [0x71, 0x73];
