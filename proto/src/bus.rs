//! The transports device drivers talk through: a full-duplex SPI transfer and plain I2C reads
//! and writes, each naming its device node so every error says which device failed.
//!
//! Drivers (`kestrel-sensors`) are generic over these traits; hardware builds plug in a Linux
//! `spidev`/`i2c-dev` handle, tests in-memory fakes, and the simulator's device emulators
//! (`kestrel-sim`'s `hil` module) answer the chips' register and command protocols with the
//! simulated world, so hardware-in-the-loop runs the real drivers. The traits live here, in the
//! contract, because the drivers and the emulators are two actor crates that never depend on
//! each other (docs/src/decisions/0017-device-emulators-behind-the-bus-traits.md).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};

/// A bus transfer that failed, naming the device node.
#[derive(Debug, thiserror::Error)]
#[error("{}: {source}", path.display())]
pub struct BusError {
    /// The device node, e.g. `/dev/spidev0.1` or `/dev/i2c-1`.
    pub path: PathBuf,
    #[source]
    pub source: std::io::Error,
}

impl BusError {
    /// An error on `path`.
    pub fn new(path: &Path, source: std::io::Error) -> BusError {
        BusError { path: path.to_path_buf(), source }
    }
}

/// One SPI device (bus and chip select).
pub trait SpiBus {
    /// The device node, for error messages.
    fn path(&self) -> &Path;

    /// One full-duplex transfer with chip select held low: the bytes of `buf` are clocked out
    /// and replaced, in place, by the bytes clocked in.
    fn transfer(&mut self, buf: &mut [u8]) -> Result<(), BusError>;
}

/// One I2C device (bus and slave address).
pub trait I2cBus {
    /// The device node, for error messages.
    fn path(&self) -> &Path;

    /// Writes `bytes` to the device in one transaction.
    fn write(&mut self, bytes: &[u8]) -> Result<(), BusError>;

    /// Reads `buf.len()` bytes from the device in one transaction.
    fn read(&mut self, buf: &mut [u8]) -> Result<(), BusError>;
}

impl<B: SpiBus + ?Sized> SpiBus for Box<B> {
    fn path(&self) -> &Path {
        (**self).path()
    }

    fn transfer(&mut self, buf: &mut [u8]) -> Result<(), BusError> {
        (**self).transfer(buf)
    }
}

impl<B: I2cBus + ?Sized> I2cBus for Box<B> {
    fn path(&self) -> &Path {
        (**self).path()
    }

    fn write(&mut self, bytes: &[u8]) -> Result<(), BusError> {
        (**self).write(bytes)
    }

    fn read(&mut self, buf: &mut [u8]) -> Result<(), BusError> {
        (**self).read(buf)
    }
}

/// Reads consecutive registers from `first` on an SPI device that marks reads with bit 7 of
/// the address byte (InvenSense, most MEMS parts).
pub fn spi_read_registers(bus: &mut impl SpiBus, first: u8, out: &mut [u8]) -> Result<(), BusError> {
    let mut buf = [0u8; 32];
    let mut done = 0;
    while done < out.len() {
        let n = (out.len() - done).min(buf.len() - 1);
        buf[0] = (first.wrapping_add(done as u8)) | 0x80;
        buf[1..=n].fill(0);
        bus.transfer(&mut buf[..=n])?;
        out[done..done + n].copy_from_slice(&buf[1..=n]);
        done += n;
    }
    Ok(())
}

/// Writes one register on an SPI device (bit 7 of the address byte clear).
pub fn spi_write_register(bus: &mut impl SpiBus, reg: u8, value: u8) -> Result<(), BusError> {
    bus.transfer(&mut [reg & 0x7F, value])
}

/// Opens a plugged-in device: a new handle on the same chip each time a driver (or its
/// restart) opens the node.
pub type SpiFactory = Arc<dyn Fn() -> Box<dyn SpiBus + Send> + Send + Sync>;
/// See [`SpiFactory`].
pub type I2cFactory = Arc<dyn Fn() -> Box<dyn I2cBus + Send> + Send + Sync>;

/// The devices plugged into this process in place of the kernel's (hardware in the loop).
///
/// A Linux `spidev` or `i2c-dev` node answers only the kernel's ioctls, so no file can stand in
/// for a chip; instead a hardware-in-the-loop run plugs its emulators in here under the node
/// paths the graph names, and a driver opening a node looks here first. The table is the
/// process's, like `/dev`: a process runs one board. Empty, every open goes to the kernel.
#[derive(Default)]
struct Plugged {
    spi: HashMap<PathBuf, SpiFactory>,
    i2c: HashMap<(PathBuf, u8), I2cFactory>,
    write_faults: HashMap<PathBuf, Arc<WriteFault>>,
}

/// A switch that makes a driver's writes to one file fail with EIO while it is on: how a
/// hardware-in-the-loop bench makes an emulated sysfs attribute (a regular file, which never
/// fails) fail as the RCIO co-processor's does when its SPI link hiccups. A driver looks its
/// file up once, when it opens it ([`write_fault`]), and checks the switch before each write
/// (one atomic load).
#[derive(Debug, Default)]
pub struct WriteFault {
    failing: AtomicBool,
}

impl WriteFault {
    /// Turns the failure on or off.
    pub fn set(&self, failing: bool) {
        self.failing.store(failing, Ordering::Relaxed);
    }

    /// `Err(EIO)` while the failure is on.
    pub fn check(&self) -> std::io::Result<()> {
        const EIO: i32 = 5; // Linux's "I/O error"
        if self.failing.load(Ordering::Relaxed) {
            Err(std::io::Error::from_raw_os_error(EIO))
        } else {
            Ok(())
        }
    }
}

static PLUGGED: Mutex<Option<Plugged>> = Mutex::new(None);

fn plugged<R>(f: impl FnOnce(&mut Plugged) -> R) -> R {
    f(PLUGGED.lock().unwrap_or_else(PoisonError::into_inner).get_or_insert_with(Plugged::default))
}

/// Plugs an SPI device in at `path` (e.g. `/dev/spidev0.1`).
pub fn plug_spi(path: &Path, open: SpiFactory) {
    plugged(|p| p.spi.insert(path.to_owned(), open));
}

/// Plugs an I2C device in at `address` on bus `path` (e.g. `/dev/i2c-1`, 0x77).
pub fn plug_i2c(path: &Path, address: u8, open: I2cFactory) {
    plugged(|p| p.i2c.insert((path.to_owned(), address), open));
}

/// The fault switch of the file at `path`, made off if there was none.
pub fn plug_write_fault(path: &Path) -> Arc<WriteFault> {
    plugged(|p| Arc::clone(p.write_faults.entry(path.to_owned()).or_default()))
}

/// The fault switch plugged in for the file at `path`, if any.
pub fn write_fault(path: &Path) -> Option<Arc<WriteFault>> {
    plugged(|p| p.write_faults.get(path).cloned())
}

/// The device plugged in at `path`, if any (else the driver opens the kernel's node).
pub fn open_plugged_spi(path: &Path) -> Option<Box<dyn SpiBus + Send>> {
    plugged(|p| p.spi.get(path).cloned()).map(|open| open())
}

/// The device plugged in at `address` on `path`, if any.
pub fn open_plugged_i2c(path: &Path, address: u8) -> Option<Box<dyn I2cBus + Send>> {
    plugged(|p| p.i2c.get(&(path.to_owned(), address)).cloned()).map(|open| open())
}
