//! The Navio2 RCIO co-processor's sysfs trees in a directory: the PWM chip the motor driver
//! writes its pulses to (kernel `Documentation/driver-api/pwm.rst`: `pwmchipN/export`,
//! `pwmM/{period,duty_cycle,enable}`, ns) and the `rcio` files the RC and power-module driver
//! reads (`rcin/ch0..`, `rcin/connected`, `adc/ch0..` in mV).
//!
//! The channels are made already exported (as the RCIO kernel driver leaves them after a first
//! export), so the driver's export step is skipped, not emulated. The simulator reads each
//! pulse as its ESC would: only while the channel is enabled, with a period set, and scaled by
//! the ESC's calibrated end points. Values the simulator writes are replaced by a rename, so a
//! driver's read sees the old number or the new one, never an empty file.

use std::io;
use std::path::{Path, PathBuf};

/// Motor channels the tree holds (RCIO exposes 14 PWM outputs; a quad uses four).
pub const RC_CHANNELS: usize = 16;
/// ADC channels of the RCIO (board voltage, servo rail, power module V and I, two spare).
pub const ADC_CHANNELS: usize = 6;

/// One ESC input: the end points it was calibrated to (µs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EscCalibration {
    /// Pulse at and below which the motor stands still.
    pub min_us: f64,
    /// Pulse for full throttle.
    pub max_us: f64,
}

impl Default for EscCalibration {
    /// The common 1000–2000 µs range.
    fn default() -> EscCalibration {
        EscCalibration { min_us: 1000.0, max_us: 2000.0 }
    }
}

/// The PWM chip's directory.
#[derive(Debug)]
pub struct PwmChip {
    channels: Vec<PathBuf>,
    esc: EscCalibration,
}

/// What an ESC makes of its input.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EscInput {
    /// No pulses (channel disabled or not set up): the ESC stays disarmed.
    NoSignal,
    /// Throttle 0..1.
    Throttle(f64),
}

impl PwmChip {
    /// Creates `<root>/pwmchip<chip>` with `channels` exported, disabled and at 0 ns.
    pub fn create(root: &Path, chip: u32, channels: &[u32], esc: EscCalibration) -> io::Result<PwmChip> {
        let chip_dir = root.join(format!("pwmchip{chip}"));
        std::fs::create_dir_all(&chip_dir)?;
        std::fs::write(chip_dir.join("export"), "")?;
        std::fs::write(chip_dir.join("npwm"), "14\n")?;
        let mut dirs = Vec::new();
        for channel in channels {
            let dir = chip_dir.join(format!("pwm{channel}"));
            std::fs::create_dir_all(&dir)?;
            for file in ["period", "duty_cycle", "enable"] {
                std::fs::write(dir.join(file), "0\n")?;
            }
            dirs.push(dir);
        }
        Ok(PwmChip { channels: dirs, esc })
    }

    /// Each channel's ESC input now, in the order the channels were given.
    pub fn read(&self) -> io::Result<Vec<EscInput>> {
        self.channels.iter().map(|dir| self.esc_input(dir)).collect()
    }

    fn esc_input(&self, dir: &Path) -> io::Result<EscInput> {
        let enabled = read_number(&dir.join("enable"))? == 1;
        let period_ns = read_number(&dir.join("period"))?;
        let duty_ns = read_number(&dir.join("duty_cycle"))?;
        if !enabled || period_ns == 0 || duty_ns == 0 || duty_ns > period_ns {
            return Ok(EscInput::NoSignal);
        }
        let us = duty_ns as f64 / 1000.0;
        let span = self.esc.max_us - self.esc.min_us;
        Ok(EscInput::Throttle(((us - self.esc.min_us) / span).clamp(0.0, 1.0)))
    }
}

/// A sysfs number as the kernel prints it; an empty file (a write in progress) reads as 0.
fn read_number(path: &Path) -> io::Result<u64> {
    let text = std::fs::read_to_string(path)?;
    let text = text.trim();
    if text.is_empty() {
        return Ok(0);
    }
    text.parse().map_err(|_| {
        io::Error::new(io::ErrorKind::InvalidData, format!("{}: not a number: {text:?}", path.display()))
    })
}

/// The `rcio` directory.
#[derive(Debug)]
pub struct RcioTree {
    root: PathBuf,
}

impl RcioTree {
    /// Creates `root` with no receiver connected and every ADC pin at 0 mV.
    pub fn create(root: &Path) -> io::Result<RcioTree> {
        std::fs::create_dir_all(root.join("rcin"))?;
        std::fs::create_dir_all(root.join("adc"))?;
        let tree = RcioTree { root: root.to_owned() };
        tree.set_rc(None)?;
        for ch in 0..ADC_CHANNELS {
            tree.replace(&format!("adc/ch{ch}"), 0)?;
        }
        Ok(tree)
    }

    /// The receiver's channels (µs), or `None` for no receiver signal (`connected` 0, every
    /// channel 0 µs).
    pub fn set_rc(&self, channels_us: Option<&[u16]>) -> io::Result<()> {
        for ch in 0..RC_CHANNELS {
            let us = channels_us.and_then(|c| c.get(ch)).copied().unwrap_or(0);
            self.replace(&format!("rcin/ch{ch}"), u64::from(us))?;
        }
        self.replace("rcin/connected", u64::from(channels_us.is_some()))
    }

    /// ADC channel `ch`'s pin voltage (mV).
    pub fn set_adc_mv(&self, ch: usize, mv: u64) -> io::Result<()> {
        self.replace(&format!("adc/ch{ch}"), mv)
    }

    fn replace(&self, relative: &str, value: u64) -> io::Result<()> {
        let path = self.root.join(relative);
        let tmp = path.with_extension("new");
        std::fs::write(&tmp, format!("{value}\n"))?;
        std::fs::rename(&tmp, &path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("kestrel-navio2-sysfs-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    #[test]
    fn pulses_become_throttle_only_while_enabled() {
        let root = temp("pwm");
        let chip = PwmChip::create(&root, 0, &[0, 3], EscCalibration::default()).expect("tree");
        assert_eq!(chip.read().expect("read"), [EscInput::NoSignal, EscInput::NoSignal]);
        let ch3 = root.join("pwmchip0/pwm3");
        std::fs::write(ch3.join("period"), "2500000").expect("write");
        std::fs::write(ch3.join("duty_cycle"), "1250000").expect("write");
        assert_eq!(chip.read().expect("read")[1], EscInput::NoSignal, "not enabled yet");
        std::fs::write(ch3.join("enable"), "1").expect("write");
        assert_eq!(chip.read().expect("read")[1], EscInput::Throttle(0.25));
        std::fs::write(ch3.join("duty_cycle"), "900000").expect("write");
        assert_eq!(chip.read().expect("read")[1], EscInput::Throttle(0.0), "below min stands still");
        std::fs::remove_dir_all(&root).ok();
    }

    #[test]
    fn rc_and_adc_files_hold_what_was_set() {
        let root = temp("rcio");
        let tree = RcioTree::create(&root).expect("tree");
        let read = |f: &str| std::fs::read_to_string(root.join(f)).expect("file").trim().to_owned();
        assert_eq!((read("rcin/connected"), read("rcin/ch2")), ("0".into(), "0".into()));
        tree.set_rc(Some(&[1500, 1500, 1100, 1500])).expect("rc");
        assert_eq!(
            (read("rcin/connected"), read("rcin/ch2"), read("rcin/ch5")),
            ("1".into(), "1100".into(), "0".into())
        );
        tree.set_adc_mv(2, 1103).expect("adc");
        assert_eq!(read("adc/ch2"), "1103");
        std::fs::remove_dir_all(&root).ok();
    }
}
