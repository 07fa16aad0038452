//! Device emulators for hardware-in-the-loop runs (issue 17): the chips of a Navio2 answering
//! their own bus protocols with the simulated world, so the real drivers of `kestrel-sensors`
//! read simulated values through the same code paths they run on a board.
//!
//! The SPI and I2C chips implement the contract's bus traits (`kestrel_proto::bus`), which the
//! drivers are generic over: the Linux backends open `/dev/spidev*` and `/dev/i2c-*` with
//! ioctls that no user-space file can answer, so the boundary is the trait. Each emulator is a
//! pure, synchronous model of its chip: the simulator sets what the world reads
//! (`set_reading`), the driver's transfers see it.

pub mod mpu9250;
pub mod ms5611;

pub use mpu9250::Mpu9250Emulator;
pub use ms5611::Ms5611Emulator;
