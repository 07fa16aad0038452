//! MEAS MS5611-01BA03 barometer (Navio2: I2C bus 1, address 0x77).
//!
//! [`prom`] checks the factory calibration with the CRC-4 of application note AN520,
//! [`compensation`] turns the raw D1/D2 conversions into temperature and pressure exactly as
//! the datasheet's integer flow, [`driver`] runs the command protocol over an [`I2cBus`],
//! [`sampler`] interleaves conversions without blocking and [`fake`] answers the protocol in
//! memory for tests.
//!
//! [`I2cBus`]: crate::bus::I2cBus

pub mod compensation;
pub mod driver;
pub mod fake;
pub mod prom;
pub mod sampler;

pub use compensation::{Compensated, compensate};
pub use driver::{Conversion, Ms5611, Ms5611Error, Oversampling};
pub use fake::FakeMs5611;
pub use prom::{Prom, PromError, crc4};
pub use sampler::Ms5611Sampler;
