//! A pseudo-terminal standing in for a UART: the driver opens the slave through a symlink (as it
//! would `/dev/ttyAMA0`) and sets its line rate with termios; the emulated device holds the
//! master, reads the line rate the driver set (a pty shares one termios between its ends) and
//! exchanges bytes without blocking.

use std::ffi::CStr;
use std::io;
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
use std::path::{Path, PathBuf};

/// termios speed codes and their rates (bit/s).
const SPEEDS: [(libc::speed_t, u32); 10] = [
    (libc::B4800, 4800),
    (libc::B9600, 9600),
    (libc::B19200, 19_200),
    (libc::B38400, 38_400),
    (libc::B57600, 57_600),
    (libc::B115200, 115_200),
    (libc::B230400, 230_400),
    (libc::B460800, 460_800),
    (libc::B921600, 921_600),
    (libc::B1000000, 1_000_000),
];

/// A pty pair and the symlink that names its slave.
#[derive(Debug)]
pub struct Pty {
    master: OwnedFd,
    /// Held open so the line stays up while the driver reopens it (a restart), as a UART does.
    _slave: OwnedFd,
    link: PathBuf,
    /// Bytes dropped because the line's buffer was full.
    pub overflowed: u64,
}

impl Pty {
    /// Opens a pty in raw mode at `initial_baud` and links `link` to its slave.
    pub fn open(link: &Path, initial_baud: u32) -> io::Result<Pty> {
        let (mut master, mut slave) = (-1, -1);
        let mut name = [0 as libc::c_char; 128];
        // SAFETY: openpty writes two descriptors and a NUL-terminated name of at most 128 bytes
        // (glibc's documented limit is the caller's buffer; the kernel's names are ~12 bytes).
        let rc = unsafe {
            libc::openpty(&mut master, &mut slave, name.as_mut_ptr(), std::ptr::null(), std::ptr::null())
        };
        if rc != 0 {
            return Err(io::Error::last_os_error());
        }
        // SAFETY: openpty succeeded, so both are open descriptors this process owns alone.
        let (master, slave) = unsafe { (OwnedFd::from_raw_fd(master), OwnedFd::from_raw_fd(slave)) };
        // SAFETY: `name` was NUL-terminated by openpty.
        let slave_path = unsafe { CStr::from_ptr(name.as_ptr()) }.to_string_lossy().into_owned();
        set_raw(&slave, initial_baud)?;
        // SAFETY: F_SETFL on an open descriptor.
        if unsafe { libc::fcntl(master.as_raw_fd(), libc::F_SETFL, libc::O_NONBLOCK) } != 0 {
            return Err(io::Error::last_os_error());
        }
        let _ = std::fs::remove_file(link);
        std::os::unix::fs::symlink(&slave_path, link)?;
        Ok(Pty { master, _slave: slave, link: link.to_owned(), overflowed: 0 })
    }

    /// The path the driver opens.
    pub fn link(&self) -> &Path {
        &self.link
    }

    /// The line rate the driver has set (bit/s), 0 if none it could name. Read with
    /// `TCGETS2`, which also sees a rate set as a number (`BOTHER`, as `serialport` sets it)
    /// rather than as a `Bnnn` code.
    pub fn line_baud(&self) -> io::Result<u32> {
        // SAFETY: a zeroed termios2 is a valid out-parameter for TCGETS2.
        let mut t: libc::termios2 = unsafe { std::mem::zeroed() };
        // SAFETY: an open descriptor and a valid termios2.
        if unsafe { libc::ioctl(self.master.as_raw_fd(), libc::TCGETS2, &mut t) } != 0 {
            return Err(io::Error::last_os_error());
        }
        let code = t.c_cflag & libc::CBAUD;
        if code == libc::BOTHER {
            return Ok(t.c_ospeed);
        }
        Ok(SPEEDS.iter().find(|(c, _)| *c == code).map_or(0, |(_, baud)| *baud))
    }

    /// What the driver has written since the last call, up to `buf.len()` bytes (0 if none).
    pub fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        // SAFETY: reads into a buffer of the given length.
        let n = unsafe { libc::read(self.master.as_raw_fd(), buf.as_mut_ptr().cast(), buf.len()) };
        if n >= 0 {
            return Ok(n as usize);
        }
        let e = io::Error::last_os_error();
        match e.kind() {
            io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted => Ok(0),
            _ => Err(e),
        }
    }

    /// Sends `bytes` to the driver; what the line cannot take now is dropped and counted (a
    /// UART overruns; a receiver never waits for its host).
    pub fn write(&mut self, bytes: &[u8]) -> io::Result<()> {
        let mut done = 0;
        while done < bytes.len() {
            let rest = &bytes[done..];
            // SAFETY: writes from a buffer of the given length.
            let n = unsafe { libc::write(self.master.as_raw_fd(), rest.as_ptr().cast(), rest.len()) };
            if n > 0 {
                done += n as usize;
                continue;
            }
            let e = io::Error::last_os_error();
            if e.kind() == io::ErrorKind::WouldBlock {
                self.overflowed += (bytes.len() - done) as u64;
                return Ok(());
            }
            return Err(e);
        }
        Ok(())
    }
}

impl Drop for Pty {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.link);
    }
}

/// Raw 8N1 at `baud` (what a UART's driver sets before it talks to a device).
fn set_raw(fd: &OwnedFd, baud: u32) -> io::Result<()> {
    let code = SPEEDS
        .iter()
        .find(|(_, b)| *b == baud)
        .map(|(code, _)| *code)
        .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, format!("no termios rate {baud}")))?;
    // SAFETY: termios calls on an open descriptor with an initialised struct.
    unsafe {
        let mut t: libc::termios = std::mem::zeroed();
        if libc::tcgetattr(fd.as_raw_fd(), &mut t) != 0 {
            return Err(io::Error::last_os_error());
        }
        libc::cfmakeraw(&mut t);
        libc::cfsetispeed(&mut t, code);
        libc::cfsetospeed(&mut t, code);
        if libc::tcsetattr(fd.as_raw_fd(), libc::TCSANOW, &t) != 0 {
            return Err(io::Error::last_os_error());
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::io::{Read, Write};

    use super::*;

    #[test]
    fn bytes_and_the_line_rate_cross_the_pair() {
        let dir = std::env::temp_dir().join(format!("kestrel-pty-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let link = dir.join("ttyGPS");
        let mut pty = Pty::open(&link, 9600).expect("a pty");
        assert_eq!(pty.line_baud().expect("termios"), 9600);
        let mut driver = std::fs::OpenOptions::new().read(true).write(true).open(&link).expect("open slave");
        set_raw(&OwnedFd::from(driver.try_clone().expect("dup")), 115_200).expect("set rate");
        assert_eq!(pty.line_baud().expect("termios"), 115_200);
        driver.write_all(b"hello").expect("write");
        std::thread::sleep(std::time::Duration::from_millis(20));
        let mut buf = [0u8; 16];
        let n = pty.read(&mut buf).expect("read");
        assert_eq!(&buf[..n], b"hello");
        assert_eq!(pty.read(&mut buf).expect("nothing more"), 0);
        pty.write(b"ack").expect("write");
        let mut got = [0u8; 3];
        driver.read_exact(&mut got).expect("read");
        assert_eq!(&got, b"ack");
        drop(pty);
        assert!(!link.exists(), "the link goes with the pty");
        std::fs::remove_dir_all(&dir).ok();
    }
}
