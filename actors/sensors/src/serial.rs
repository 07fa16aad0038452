//! Serial ports for the byte-stream drivers (GPS, SBUS).
//!
//! Drivers read and write through [`SerialTransport`]: any async byte stream that can also
//! change its line rate. Hardware runs and the tests use a `tokio-serial` port: a UART, or in
//! tests one end of a pseudo-terminal pair (a real tty with real termios).

use std::path::{Path, PathBuf};

use tokio::io::{AsyncRead, AsyncWrite};
use tokio_serial::{DataBits, Parity, SerialPort, SerialPortBuilderExt, SerialStream, StopBits};

/// A byte stream to a device on a UART.
pub trait SerialTransport: AsyncRead + AsyncWrite + Unpin + Send + 'static {
    /// Changes the line rate (bit/s), e.g. after telling a GPS receiver to switch.
    fn set_baud_rate(&mut self, baud: u32) -> std::io::Result<()>;
}

impl SerialTransport for SerialStream {
    fn set_baud_rate(&mut self, baud: u32) -> std::io::Result<()> {
        SerialPort::set_baud_rate(self, baud).map_err(std::io::Error::from)
    }
}

/// Line settings: rate and character framing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LineSettings {
    /// Bit/s.
    pub baud: u32,
    pub parity: Parity,
    pub stop_bits: StopBits,
}

impl LineSettings {
    /// 8 data bits, no parity, 1 stop bit (GPS receivers, radios).
    pub fn n81(baud: u32) -> LineSettings {
        LineSettings { baud, parity: Parity::None, stop_bits: StopBits::One }
    }

    /// SBUS: 100 000 bit/s, 8 data bits, even parity, 2 stop bits.
    pub fn sbus() -> LineSettings {
        LineSettings { baud: 100_000, parity: Parity::Even, stop_bits: StopBits::Two }
    }
}

/// A serial port that could not be opened or set up.
#[derive(Debug, thiserror::Error)]
#[error("{what} on serial port {}: {source}", path.display())]
pub struct SerialError {
    /// The device node, e.g. `/dev/ttyAMA0`.
    pub path: PathBuf,
    /// What was expected there, e.g. "u-blox GPS receiver at 9600 baud".
    pub what: String,
    #[source]
    pub source: tokio_serial::Error,
}

/// Opens `path` with `settings`, no flow control. Must be called inside a tokio runtime.
pub fn open(path: &Path, settings: LineSettings, what: &str) -> Result<SerialStream, SerialError> {
    tokio_serial::new(path.to_string_lossy(), settings.baud)
        .data_bits(DataBits::Eight)
        .parity(settings.parity)
        .stop_bits(settings.stop_bits)
        .open_native_async()
        .map_err(|source| SerialError { path: path.to_owned(), what: what.to_owned(), source })
}
