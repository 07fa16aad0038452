//! An I2C device through `/dev/i2c-N`: bind the slave address with `I2C_SLAVE`, then plain
//! `read`/`write` are bus transactions (kernel Documentation/i2c/dev-interface.rst).

use std::ffi::c_ulong;
use std::fs::{File, OpenOptions};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use crate::bus::{BusError, I2cBus};
use crate::linux::ioctl::ioctl_arg;

/// `I2C_SLAVE` from `linux/i2c-dev.h`.
const I2C_SLAVE: c_ulong = 0x0703;

/// One slave on a Linux I2C adapter.
#[derive(Debug)]
pub struct LinuxI2c {
    file: File,
    path: PathBuf,
}

impl LinuxI2c {
    /// Opens adapter `path` (e.g. `/dev/i2c-1`) for the 7-bit slave `address`.
    pub fn open(path: &Path, address: u8) -> Result<LinuxI2c, BusError> {
        let file =
            OpenOptions::new().read(true).write(true).open(path).map_err(|e| BusError::new(path, e))?;
        // SAFETY: I2C_SLAVE takes the address as an integer argument, not a pointer.
        unsafe { ioctl_arg(&file, I2C_SLAVE, usize::from(address)) }.map_err(|e| BusError::new(path, e))?;
        Ok(LinuxI2c { file, path: path.to_path_buf() })
    }
}

impl I2cBus for LinuxI2c {
    fn path(&self) -> &Path {
        &self.path
    }

    fn write(&mut self, bytes: &[u8]) -> Result<(), BusError> {
        self.file.write_all(bytes).map_err(|e| BusError::new(&self.path, e))
    }

    fn read(&mut self, buf: &mut [u8]) -> Result<(), BusError> {
        self.file.read_exact(buf).map_err(|e| BusError::new(&self.path, e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_adapter_names_its_path() {
        let err = LinuxI2c::open(Path::new("/dev/i2c-kestrel-missing"), 0x77).expect_err("no such device");
        assert!(err.to_string().starts_with("/dev/i2c-kestrel-missing: "), "{err}");
    }

    #[test]
    fn a_file_that_is_not_an_adapter_is_refused() {
        let path = std::env::temp_dir().join(format!("kestrel-not-i2c-{}", std::process::id()));
        std::fs::write(&path, b"").expect("temp file");
        let err = LinuxI2c::open(&path, 0x77).expect_err("not an I2C adapter");
        let _ = std::fs::remove_file(&path);
        assert_eq!(err.source.raw_os_error(), Some(25), "ENOTTY expected: {err}");
    }
}
