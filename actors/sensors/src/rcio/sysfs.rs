//! The RCIO sysfs files: `rcin/ch0..` (RC input pulse widths, µs), `rcin/connected` (1 while
//! the receiver delivers frames), and `adc/ch0..` (millivolts at the ADC pins).

use std::path::{Path, PathBuf};

/// A file that is missing, unreadable or not a number.
#[derive(Debug, thiserror::Error)]
pub enum RcioError {
    #[error("{}: {source} (is the Navio2 rcio driver loaded?)", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: expected a whole number, read {text:?}", path.display())]
    Value { path: PathBuf, text: String },
}

/// The RCIO directory (`/sys/kernel/rcio`, a temporary directory in tests).
#[derive(Clone, Debug)]
pub struct RcioSysfs {
    root: PathBuf,
}

impl RcioSysfs {
    pub fn new(root: &Path) -> RcioSysfs {
        RcioSysfs { root: root.to_owned() }
    }

    /// The directory, for messages.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// RC input channel `index` (0-based, as the files are numbered): pulse width (µs).
    pub fn rc_channel_us(&self, index: usize) -> Result<u16, RcioError> {
        let path = self.root.join(format!("rcin/ch{index}"));
        let value = read_number(&path)?;
        u16::try_from(value).map_err(|_| RcioError::Value { path, text: value.to_string() })
    }

    /// Whether the receiver is delivering frames; `None` when the driver has no `connected`
    /// file (older RCIO firmware).
    pub fn rc_connected(&self) -> Result<Option<bool>, RcioError> {
        let path = self.root.join("rcin/connected");
        match std::fs::read_to_string(&path) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(source) => Err(RcioError::Read { path, source }),
            Ok(text) => parse(&path, &text).map(|v| Some(v != 0)),
        }
    }

    /// ADC channel `index`: the voltage at its pin (mV).
    pub fn adc_mv(&self, index: usize) -> Result<u32, RcioError> {
        let path = self.root.join(format!("adc/ch{index}"));
        let value = read_number(&path)?;
        u32::try_from(value).map_err(|_| RcioError::Value { path, text: value.to_string() })
    }
}

fn read_number(path: &Path) -> Result<i64, RcioError> {
    let text =
        std::fs::read_to_string(path).map_err(|source| RcioError::Read { path: path.to_owned(), source })?;
    parse(path, &text)
}

fn parse(path: &Path, text: &str) -> Result<i64, RcioError> {
    text.trim().parse().map_err(|_| RcioError::Value { path: path.to_owned(), text: text.trim().to_owned() })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A temporary directory laid out like `/sys/kernel/rcio`.
    pub(crate) struct FakeRcio {
        pub root: PathBuf,
    }

    impl FakeRcio {
        pub(crate) fn new(name: &str) -> FakeRcio {
            let root = std::env::temp_dir().join(format!("kestrel-rcio-{name}-{}", std::process::id()));
            let _ = std::fs::remove_dir_all(&root);
            std::fs::create_dir_all(root.join("rcin")).expect("temp dir");
            std::fs::create_dir_all(root.join("adc")).expect("temp dir");
            FakeRcio { root }
        }

        pub(crate) fn set(&self, file: &str, text: &str) {
            std::fs::write(self.root.join(file), text).expect("write fake sysfs file");
        }
    }

    impl Drop for FakeRcio {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.root);
        }
    }

    #[test]
    fn reads_channels_and_names_missing_or_bad_files() {
        let fake = FakeRcio::new("read");
        fake.set("rcin/ch0", "1502\n");
        fake.set("adc/ch2", "1234\n");
        fake.set("rcin/ch1", "n/a\n");
        let rcio = RcioSysfs::new(&fake.root);
        assert_eq!(rcio.rc_channel_us(0).expect("ch0"), 1502);
        assert_eq!(rcio.adc_mv(2).expect("adc ch2"), 1234);
        assert_eq!(rcio.rc_connected().expect("no file"), None);
        fake.set("rcin/connected", "0\n");
        assert_eq!(rcio.rc_connected().expect("file"), Some(false));
        let missing = rcio.rc_channel_us(5).expect_err("no ch5").to_string();
        assert!(missing.contains(&fake.root.join("rcin/ch5").display().to_string()), "{missing}");
        let bad = rcio.rc_channel_us(1).expect_err("not a number").to_string();
        assert!(bad.contains("rcin/ch1") && bad.contains("n/a"), "{bad}");
    }
}
