//! InvenSense MPU-9250 (Navio2: `/dev/spidev0.1`) with its AK8963 magnetometer behind the
//! MPU's auxiliary I2C master: [`registers`] is the register map, [`scale`] the ranges and
//! raw → SI conversion, [`reading`] one converted sample in body FRD, [`driver`] the
//! configuration sequence and burst read over an [`SpiBus`](crate::bus::SpiBus), and
//! [`fake`] a register-level stand-in for tests.

pub mod driver;
pub mod fake;
pub mod reading;
pub mod registers;
pub mod scale;

pub use driver::{Mpu9250, Mpu9250Config, Mpu9250Error};
pub use fake::FakeMpu9250;
pub use reading::{ImuReading, RawImu};
pub use scale::{AccelRange, Dlpf, GyroRange};
