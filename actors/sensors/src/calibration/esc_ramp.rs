//! The pulse ramp an ESC range calibration drives every output through: from below any ESC's
//! start to past any ESC's full speed, in equal steps, each held long enough for the motor to
//! settle (five of its time constants) before its speed is read. All outputs ramp together,
//! propellers off, as PX4's `esc_calibration.cpp` drives them all at once.

use kestrel_proto::esc::{SAFE_PULSE_MAX_US, SAFE_PULSE_MIN_US};

/// A ramp of pulses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EscRamp {
    from_us: u32,
    to_us: u32,
    step_us: u32,
    dwell_s: f64,
}

/// Why a ramp cannot be driven.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum InvalidRamp {
    #[error("ramp {from_us}..={to_us} µs must rise within {SAFE_PULSE_MIN_US}..={SAFE_PULSE_MAX_US} µs")]
    Range { from_us: u32, to_us: u32 },
    #[error("ramp step {step_us} µs must be 1..=100 µs")]
    Step { step_us: u32 },
    #[error("ramp dwell {dwell_s} s must be finite, 0.02..=2 s")]
    Dwell { dwell_s: f64 },
}

impl EscRamp {
    /// Pulses `from_us`, `from_us + step_us`, ... up to `to_us`, each held `dwell_s`.
    pub fn new(from_us: u32, to_us: u32, step_us: u32, dwell_s: f64) -> Result<EscRamp, InvalidRamp> {
        let safe = |us: u32| (SAFE_PULSE_MIN_US..=SAFE_PULSE_MAX_US).contains(&f64::from(us));
        if !(safe(from_us) && safe(to_us) && from_us < to_us) {
            return Err(InvalidRamp::Range { from_us, to_us });
        }
        if !(1..=100).contains(&step_us) {
            return Err(InvalidRamp::Step { step_us });
        }
        if !(dwell_s.is_finite() && (0.02..=2.0).contains(&dwell_s)) {
            return Err(InvalidRamp::Dwell { dwell_s });
        }
        Ok(EscRamp { from_us, to_us, step_us, dwell_s })
    }

    /// How many pulses the ramp holds.
    pub fn steps(&self) -> usize {
        ((self.to_us - self.from_us) / self.step_us + 1) as usize
    }

    /// The pulse of step `index` (µs); `None` past the end.
    pub fn pulse_us(&self, index: usize) -> Option<u32> {
        let index = u32::try_from(index).ok().filter(|&i| (i as usize) < self.steps())?;
        Some(self.from_us + index * self.step_us)
    }

    /// How long each pulse is held (s).
    pub fn dwell_s(&self) -> f64 {
        self.dwell_s
    }

    /// How long the whole ramp takes (s).
    pub fn duration_s(&self) -> f64 {
        self.steps() as f64 * self.dwell_s
    }

    pub fn from_us(&self) -> u32 {
        self.from_us
    }

    pub fn to_us(&self) -> u32 {
        self.to_us
    }
}

impl Default for EscRamp {
    /// 900..=2100 µs in 4 µs steps of 0.2 s (five time constants of a 0.04 s motor): below any
    /// ESC's start and 30 µs (`EscSettings::min_plateau_us`) past a full speed as late as 2070 µs;
    /// 301 steps, 60 s.
    fn default() -> EscRamp {
        EscRamp { from_us: 900, to_us: 2100, step_us: 4, dwell_s: 0.2 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ramp_rises_in_equal_steps_inside_the_safe_range() {
        let ramp = EscRamp::new(900, 2100, 4, 0.2).expect("valid");
        assert_eq!(ramp, EscRamp::default());
        assert_eq!(ramp.steps(), 301);
        assert_eq!(ramp.pulse_us(0), Some(900));
        assert_eq!(ramp.pulse_us(300), Some(2100));
        assert_eq!(ramp.pulse_us(301), None);
        assert!((ramp.duration_s() - 60.2).abs() < 1e-9);
        let pulses: Vec<u32> = (0..ramp.steps()).map_while(|i| ramp.pulse_us(i)).collect();
        assert!(pulses.windows(2).all(|w| w[1] - w[0] == 4));
        // A step that does not divide the span stops short of `to_us`, never past it.
        let odd = EscRamp::new(1000, 1010, 3, 0.1).expect("valid");
        assert_eq!((0..5).map_while(|i| odd.pulse_us(i)).collect::<Vec<_>>(), [1000, 1003, 1006, 1009]);
    }

    #[test]
    fn an_unsafe_or_degenerate_ramp_is_refused() {
        assert!(matches!(EscRamp::new(700, 2000, 4, 0.2), Err(InvalidRamp::Range { .. })));
        assert!(matches!(EscRamp::new(1000, 2300, 4, 0.2), Err(InvalidRamp::Range { .. })));
        assert!(matches!(EscRamp::new(1500, 1500, 4, 0.2), Err(InvalidRamp::Range { .. })));
        assert!(matches!(EscRamp::new(1000, 2000, 0, 0.2), Err(InvalidRamp::Step { .. })));
        for dwell_s in [f64::NAN, f64::INFINITY, 0.0, 0.01, 3.0] {
            assert!(
                matches!(EscRamp::new(1000, 2000, 4, dwell_s), Err(InvalidRamp::Dwell { .. })),
                "{dwell_s}"
            );
        }
    }
}
