//! An SPI device through `/dev/spidevB.C` (kernel Documentation/spi/spidev.rst): mode and
//! clock set once, then each transfer is one `SPI_IOC_MESSAGE(1)` full-duplex message.

use std::ffi::c_ulong;
use std::fs::{File, OpenOptions};
use std::path::{Path, PathBuf};

use crate::bus::{BusError, SpiBus};
use crate::linux::ioctl::ioctl_arg;

/// `SPI_IOC_WR_MODE`: `_IOW('k', 1, __u8)`.
const SPI_IOC_WR_MODE: c_ulong = 0x4001_6B01;
/// `SPI_IOC_WR_MAX_SPEED_HZ`: `_IOW('k', 4, __u32)`.
const SPI_IOC_WR_MAX_SPEED_HZ: c_ulong = 0x4004_6B04;
/// `SPI_IOC_MESSAGE(1)`: `_IOW('k', 0, char[32])`.
const SPI_IOC_MESSAGE_1: c_ulong = 0x4020_6B00;

/// `struct spi_ioc_transfer` (32 bytes).
#[repr(C)]
#[derive(Default)]
struct SpiIocTransfer {
    tx_buf: u64,
    rx_buf: u64,
    len: u32,
    speed_hz: u32,
    delay_usecs: u16,
    bits_per_word: u8,
    cs_change: u8,
    tx_nbits: u8,
    rx_nbits: u8,
    word_delay_usecs: u8,
    pad: u8,
}

/// One SPI device.
#[derive(Debug)]
pub struct LinuxSpi {
    file: File,
    path: PathBuf,
    speed_hz: u32,
}

impl LinuxSpi {
    /// Opens `path` in SPI `mode` (0..3; InvenSense parts use 3 or 0) at `speed_hz`.
    pub fn open(path: &Path, mode: u8, speed_hz: u32) -> Result<LinuxSpi, BusError> {
        let file =
            OpenOptions::new().read(true).write(true).open(path).map_err(|e| BusError::new(path, e))?;
        let mode = mode & 0x03;
        // SAFETY: both requests read one value of the declared width through the pointer,
        // which points at a live local of that width.
        unsafe {
            ioctl_arg(&file, SPI_IOC_WR_MODE, &mode as *const u8 as usize)
                .map_err(|e| BusError::new(path, e))?;
            ioctl_arg(&file, SPI_IOC_WR_MAX_SPEED_HZ, &speed_hz as *const u32 as usize)
                .map_err(|e| BusError::new(path, e))?;
        }
        Ok(LinuxSpi { file, path: path.to_path_buf(), speed_hz })
    }
}

impl SpiBus for LinuxSpi {
    fn path(&self) -> &Path {
        &self.path
    }

    fn transfer(&mut self, buf: &mut [u8]) -> Result<(), BusError> {
        let len = u32::try_from(buf.len())
            .map_err(|_| BusError::new(&self.path, std::io::Error::from(std::io::ErrorKind::InvalidInput)))?;
        let ptr = buf.as_mut_ptr() as u64;
        let transfer = SpiIocTransfer {
            tx_buf: ptr,
            rx_buf: ptr,
            len,
            speed_hz: self.speed_hz,
            bits_per_word: 8,
            ..SpiIocTransfer::default()
        };
        // SAFETY: `transfer` is a valid spi_ioc_transfer whose tx/rx buffers both point at
        // `buf` (spidev allows them to alias) of `len` bytes, alive for the call.
        unsafe { ioctl_arg(&self.file, SPI_IOC_MESSAGE_1, &transfer as *const SpiIocTransfer as usize) }
            .map_err(|e| BusError::new(&self.path, e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_transfer_struct_matches_the_kernel_layout() {
        assert_eq!(std::mem::size_of::<SpiIocTransfer>(), 32);
    }

    #[test]
    fn a_missing_device_names_its_path() {
        let err =
            LinuxSpi::open(Path::new("/dev/spidev-kestrel-missing"), 3, 1_000_000).expect_err("missing");
        assert!(err.to_string().starts_with("/dev/spidev-kestrel-missing: "), "{err}");
    }
}
