//! Linux implementations of the bus traits: `i2c-dev` ([`LinuxI2c`]) and `spidev`
//! ([`LinuxSpi`]), through their character devices and ioctls. The ioctl numbers and the
//! `spi_ioc_transfer` layout are those of the kernel's UAPI headers `linux/i2c-dev.h` and
//! `linux/spi/spidev.h`.

pub mod i2c;
mod ioctl;
pub mod spi;

pub use i2c::LinuxI2c;
pub use spi::LinuxSpi;
