//! Device emulators for hardware-in-the-loop runs: the chips of a Navio2 answering
//! their own bus protocols with the simulated world, so the real drivers of `kestrel-sensors`
//! read simulated values through the same code paths they run on a board.
//!
//! The SPI and I2C chips implement the contract's bus traits (`kestrel_proto::bus`), which the
//! drivers are generic over: the Linux backends open `/dev/spidev*` and `/dev/i2c-*` with
//! ioctls that no user-space file can answer, so the boundary is the trait, and the bench plugs
//! them into the contract's table of devices. The u-blox receiver sits on a pseudo-terminal and
//! the RCIO's PWM and `rcio` files in a directory: the OS boundaries their drivers already
//! cross. Each emulator is a pure, synchronous model of its device; the simulator sets what
//! the world reads through a shared handle, the driver's transfers see it.

pub mod actor;
pub mod bench;
pub mod mpu9250;
pub mod ms5611;
pub mod navio2_sysfs;
pub mod pty;
pub mod ublox;

pub use actor::HilSimActor;
pub use bench::{BenchConfig, Navio2Bench};
pub use mpu9250::{Mpu9250Emulator, Mpu9250World};
pub use ms5611::{Ms5611Emulator, Ms5611World};
pub use ublox::UbloxReceiver;
