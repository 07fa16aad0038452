//! One channel of the Linux PWM sysfs interface (kernel Documentation/driver-api/pwm.rst,
//! "Using PWMs with the sysfs interface"): write the channel number to
//! `<root>/pwmchipN/export`, then `period` and `duty_cycle` (ns) and `enable` (1) under
//! `<root>/pwmchipN/pwmM/`. The root is configurable so tests use a temporary directory as
//! a fake `/sys/class/pwm`.

use std::fs::File;
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use kestrel_proto::bus::WriteFault;

/// How long to wait for an exported channel's directory to appear (udev may also need to fix
/// its permissions), in polls of [`EXPORT_POLL`].
pub const EXPORT_POLLS: u32 = 50;
/// Interval between checks for an exported channel's directory.
pub const EXPORT_POLL: Duration = Duration::from_millis(2);

/// A PWM file that could not be used.
#[derive(Debug, thiserror::Error)]
pub enum PwmError {
    #[error("{}: {source} (expected a Linux PWM chip; is the RCIO/PWM driver loaded?)", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{} did not appear after exporting the channel", path.display())]
    NotExported { path: PathBuf },
    #[error("invalid pulse configuration: {0}")]
    Config(String),
}

fn write(path: PathBuf, value: impl std::fmt::Display) -> Result<(), PwmError> {
    std::fs::write(&path, value.to_string()).map_err(|source| PwmError::Io { path, source })
}

/// An exported, configured channel, its `duty_cycle` kept open: a pulse is one `pwrite` at
/// offset 0 (each write to a sysfs attribute is one `store` in the driver), with no open, no
/// path and no allocation per command.
#[derive(Debug)]
pub struct PwmChannel {
    dir: PathBuf,
    duty_path: PathBuf,
    duty: File,
    /// Length of the last value written, to trim a longer one left in a regular file.
    written_len: usize,
    /// A hardware-in-the-loop bench's fault switch for this file, if one is plugged in.
    fault: Option<Arc<WriteFault>>,
}

impl PwmChannel {
    /// Exports channel `channel` of `<root>/pwmchip<chip>` if needed, sets `period_ns`, the
    /// initial pulse `duty_ns`, and enables it. `sleep` waits between checks for the exported
    /// directory.
    pub fn open(
        root: &Path,
        chip: u32,
        channel: u32,
        period_ns: u64,
        duty_ns: u64,
        sleep: &mut impl FnMut(Duration),
    ) -> Result<PwmChannel, PwmError> {
        let chip_dir = root.join(format!("pwmchip{chip}"));
        let dir = chip_dir.join(format!("pwm{channel}"));
        if !dir.is_dir() {
            write(chip_dir.join("export"), channel)?;
            let mut polls = 0;
            while !dir.is_dir() {
                if polls == EXPORT_POLLS {
                    return Err(PwmError::NotExported { path: dir });
                }
                sleep(EXPORT_POLL);
                polls += 1;
            }
        }
        // A duty cycle longer than the new period would be refused, so clear it first.
        write(dir.join("duty_cycle"), 0)?;
        write(dir.join("period"), period_ns)?;
        write(dir.join("duty_cycle"), duty_ns)?;
        write(dir.join("enable"), 1)?;
        let duty_path = dir.join("duty_cycle");
        let duty = std::fs::OpenOptions::new()
            .write(true)
            .open(&duty_path)
            .map_err(|source| PwmError::Io { path: duty_path.clone(), source })?;
        let written_len = decimal(duty_ns, &mut [0; 20]).len();
        let fault = kestrel_proto::bus::write_fault(&duty_path);
        Ok(PwmChannel { duty_path, dir, duty, written_len, fault })
    }

    /// Sets the pulse width (ns). A regular file standing in for the attribute (tests, the HIL
    /// bench) is cut to the new length; sysfs has no length to cut, and the error of trying is
    /// not the write's.
    pub fn set_duty_ns(&mut self, duty_ns: u64) -> std::io::Result<()> {
        if let Some(fault) = &self.fault {
            fault.check()?;
        }
        let mut buf = [0; 20];
        let text = decimal(duty_ns, &mut buf);
        self.duty.write_all_at(text, 0)?;
        if text.len() < self.written_len {
            let _ = self.duty.set_len(text.len() as u64);
        }
        self.written_len = text.len();
        Ok(())
    }

    /// The `duty_cycle` file, for reports.
    pub fn duty_path(&self) -> &Path {
        &self.duty_path
    }

    /// The channel's directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }
}

/// `value` in decimal ASCII, in `buf`.
fn decimal(mut value: u64, buf: &mut [u8; 20]) -> &[u8] {
    let mut start = buf.len();
    loop {
        start -= 1;
        buf[start] = b'0' + (value % 10) as u8;
        value /= 10;
        if value == 0 {
            return &buf[start..];
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A temporary fake `/sys/class/pwm`, removed on drop.
    pub(crate) struct FakePwmRoot {
        pub(crate) root: PathBuf,
    }

    impl FakePwmRoot {
        /// A root with `pwmchip<chip>` whose channels `present` are already exported.
        pub(crate) fn new(name: &str, chip: u32, present: &[u32]) -> FakePwmRoot {
            let root = std::env::temp_dir().join(format!("kestrel-pwm-{}-{name}", std::process::id()));
            let _ = std::fs::remove_dir_all(&root);
            let chip_dir = root.join(format!("pwmchip{chip}"));
            std::fs::create_dir_all(&chip_dir).expect("temp dir");
            for channel in present {
                std::fs::create_dir_all(chip_dir.join(format!("pwm{channel}"))).expect("temp dir");
            }
            FakePwmRoot { root }
        }

        pub(crate) fn read(&self, relative: &str) -> String {
            std::fs::read_to_string(self.root.join(relative)).unwrap_or_default()
        }
    }

    impl Drop for FakePwmRoot {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.root);
        }
    }

    #[test]
    fn configures_an_exported_channel() {
        let fake = FakePwmRoot::new("configure", 0, &[3]);
        let mut channel =
            PwmChannel::open(&fake.root, 0, 3, 2_500_000, 1_000_000, &mut |_| {}).expect("open");
        assert_eq!(fake.read("pwmchip0/pwm3/period"), "2500000");
        assert_eq!(fake.read("pwmchip0/pwm3/duty_cycle"), "1000000");
        assert_eq!(fake.read("pwmchip0/pwm3/enable"), "1");
        channel.set_duty_ns(1_500_000).expect("write");
        assert_eq!(fake.read("pwmchip0/pwm3/duty_cycle"), "1500000");
        channel.set_duty_ns(900_000).expect("write");
        assert_eq!(fake.read("pwmchip0/pwm3/duty_cycle"), "900000", "no digit of the longer value left");
        channel.set_duty_ns(12_345_678).expect("write");
        assert_eq!(fake.read("pwmchip0/pwm3/duty_cycle"), "12345678");
    }

    #[test]
    fn decimal_is_the_number_in_ascii() {
        for v in [0u64, 7, 10, 999_999, 1_000_000, u64::MAX] {
            assert_eq!(decimal(v, &mut [0; 20]), v.to_string().as_bytes());
        }
    }

    #[test]
    fn exports_a_missing_channel_and_waits_for_it() {
        let fake = FakePwmRoot::new("export", 0, &[]);
        let dir = fake.root.join("pwmchip0/pwm5");
        let mut polls = 0;
        let channel = PwmChannel::open(&fake.root, 0, 5, 2_500_000, 1_000_000, &mut |_| {
            // The "kernel" creates the directory after a while.
            polls += 1;
            if polls == 3 {
                std::fs::create_dir_all(&dir).expect("temp dir");
            }
        });
        assert!(channel.is_ok());
        assert_eq!(fake.read("pwmchip0/export"), "5");
    }

    #[test]
    fn a_missing_chip_or_channel_names_the_path() {
        let fake = FakePwmRoot::new("missing", 0, &[]);
        let err = PwmChannel::open(&fake.root, 1, 0, 2_500_000, 1_000_000, &mut |_| {}).expect_err("no chip");
        assert!(err.to_string().contains("pwmchip1/export"), "{err}");
        let err =
            PwmChannel::open(&fake.root, 0, 2, 2_500_000, 1_000_000, &mut |_| {}).expect_err("no channel");
        assert!(matches!(err, PwmError::NotExported { .. }));
        assert!(err.to_string().contains("pwmchip0/pwm2"), "{err}");
    }
}
