//! ESC range: per output, the pulse at which the motor starts to turn and the pulse beyond
//! which it turns no faster, from a recorded ramp (props off, the shell's safety checks
//! passed) of pulse width against motor speed (ESC telemetry or an RPM sensor).
//!
//! ESCs of one make still differ per unit; mapping command 0..1 onto each output's own
//! `start_us..full_us` makes equal commands give equal thrust (what ArduPilot's
//! `MOT_PWM_MIN/MAX` and `MOT_SPIN_ARM` approximate for all outputs at once).

/// One recorded point of a ramp.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EscSample {
    /// Pulse width sent (µs).
    pub pulse_us: u32,
    /// Motor speed measured at that pulse (rad/s).
    pub speed_rad_s: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EscSettings {
    /// Fewest samples per output.
    pub min_samples: usize,
    /// A motor turning slower than this at the top of the ramp never turned (rad/s).
    pub min_top_speed_rad_s: f64,
    /// Share of the top speed that counts as "turning".
    pub start_fraction: f64,
    /// Share of the top speed that counts as "full".
    pub full_fraction: f64,
    /// Pulses above `full_us` that must stay at full speed: the ramp went past saturation.
    pub min_plateau_us: u32,
    /// Largest drop of speed as the pulse rises, as a share of the top speed.
    pub max_drop_fraction: f64,
}

impl Default for EscSettings {
    fn default() -> EscSettings {
        EscSettings {
            min_samples: 20,
            min_top_speed_rad_s: 50.0,
            start_fraction: 0.05,
            full_fraction: 0.98,
            min_plateau_us: 30,
            max_drop_fraction: 0.1,
        }
    }
}

/// One output's usable pulse range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EscRange {
    /// Lowest pulse at which the motor turns (µs): command 0 while armed.
    pub start_us: u32,
    /// Lowest pulse reaching `full_fraction` of the top speed (µs): command 1.
    pub full_us: u32,
    /// Top speed seen (rad/s).
    pub top_speed_rad_s: f64,
}

impl EscRange {
    /// The pulse for `command` (0..1, clamped; NaN counts as 0) on this output (µs).
    pub fn pulse_us(&self, command: f64) -> u32 {
        let c = if command.is_nan() { 0.0 } else { command.clamp(0.0, 1.0) };
        self.start_us + (c * f64::from(self.full_us - self.start_us)).round() as u32
    }
}

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EscCalError {
    #[error("output {output}: {got} samples, at least {need} needed")]
    TooFewSamples { output: usize, got: usize, need: usize },
    #[error("output {output}: sample {index} speed is not finite")]
    NonFinite { output: usize, index: usize },
    #[error("output {output}: pulses do not rise at sample {index}: not a ramp")]
    NotARamp { output: usize, index: usize },
    #[error(
        "output {output}: the motor never turned (top speed {top_speed_rad_s:.1} rad/s): ESC unpowered or not connected"
    )]
    NeverTurned { output: usize, top_speed_rad_s: f64 },
    #[error(
        "output {output}: the motor already turned at the ramp's first pulse {pulse_us} µs: start the ramp lower"
    )]
    StartedTurning { output: usize, pulse_us: u32 },
    #[error(
        "output {output}: full speed only from {full_us} µs, {plateau_us} µs before the ramp's end (at least {need_us} needed): ramp higher"
    )]
    NoPlateau { output: usize, full_us: u32, plateau_us: u32, need_us: u32 },
    #[error(
        "output {output}: speed fell by {drop_fraction:.0}% of top speed at {pulse_us} µs: the motor stalled or the data is mixed up"
    )]
    SpeedFell { output: usize, pulse_us: u32, drop_fraction: f64 },
}

/// Each output's range from its ramp (`ramps[i]` for output `i`, pulses rising).
pub fn calibrate_esc(ramps: &[Vec<EscSample>], settings: &EscSettings) -> Result<Vec<EscRange>, EscCalError> {
    ramps.iter().enumerate().map(|(output, ramp)| range_of(output, ramp, settings)).collect()
}

fn range_of(output: usize, ramp: &[EscSample], settings: &EscSettings) -> Result<EscRange, EscCalError> {
    if ramp.len() < settings.min_samples.max(2) {
        return Err(EscCalError::TooFewSamples {
            output,
            got: ramp.len(),
            need: settings.min_samples.max(2),
        });
    }
    for (index, s) in ramp.iter().enumerate() {
        if !s.speed_rad_s.is_finite() {
            return Err(EscCalError::NonFinite { output, index });
        }
        if index > 0 && s.pulse_us <= ramp[index - 1].pulse_us {
            return Err(EscCalError::NotARamp { output, index });
        }
    }
    let top_speed_rad_s = ramp.iter().map(|s| s.speed_rad_s).fold(f64::MIN, f64::max);
    if top_speed_rad_s < settings.min_top_speed_rad_s {
        return Err(EscCalError::NeverTurned { output, top_speed_rad_s });
    }
    let mut highest = f64::MIN;
    for s in ramp {
        highest = highest.max(s.speed_rad_s);
        let drop_fraction = (highest - s.speed_rad_s) / top_speed_rad_s;
        if drop_fraction > settings.max_drop_fraction {
            return Err(EscCalError::SpeedFell {
                output,
                pulse_us: s.pulse_us,
                drop_fraction: drop_fraction * 100.0,
            });
        }
    }
    let first_at = |fraction: f64| ramp.iter().position(|s| s.speed_rad_s >= fraction * top_speed_rad_s);
    let start = first_at(settings.start_fraction).unwrap_or(0);
    if start == 0 {
        return Err(EscCalError::StartedTurning { output, pulse_us: ramp[0].pulse_us });
    }
    let full = first_at(settings.full_fraction).unwrap_or(ramp.len() - 1);
    let (full_us, last_us) = (ramp[full].pulse_us, ramp[ramp.len() - 1].pulse_us);
    if last_us - full_us < settings.min_plateau_us {
        return Err(EscCalError::NoPlateau {
            output,
            full_us,
            plateau_us: last_us - full_us,
            need_us: settings.min_plateau_us,
        });
    }
    // The motor starts between the last still pulse and the first turning one.
    let start_us = (ramp[start - 1].pulse_us + ramp[start].pulse_us).div_ceil(2);
    Ok(EscRange { start_us, full_us, top_speed_rad_s })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A motor that starts at `start_us`, speeds up linearly and saturates at `full_us`.
    fn ramp(start_us: u32, full_us: u32, to_us: u32) -> Vec<EscSample> {
        (1000..=to_us)
            .step_by(5)
            .map(|pulse_us| {
                let x = (f64::from(pulse_us) - f64::from(start_us)) / f64::from(full_us - start_us);
                let speed_rad_s = if pulse_us < start_us { 0.0 } else { 100.0 + 900.0 * x.min(1.0) };
                EscSample { pulse_us, speed_rad_s }
            })
            .collect()
    }

    #[test]
    fn each_output_gets_its_own_range_and_bad_ramps_are_refused() {
        let ramps = vec![ramp(1080, 1900, 2000), ramp(1120, 1950, 2000)];
        let ranges = calibrate_esc(&ramps, &EscSettings::default()).expect("good ramps");
        assert!(
            ranges[0].start_us.abs_diff(1080) <= 5 && ranges[1].start_us.abs_diff(1120) <= 5,
            "{ranges:?}"
        );
        assert!(
            ranges[0].full_us.abs_diff(1900) <= 20 && ranges[1].full_us.abs_diff(1950) <= 20,
            "{ranges:?}"
        );
        assert_eq!(ranges[1].pulse_us(0.0), ranges[1].start_us);
        assert_eq!(ranges[1].pulse_us(f64::NAN), ranges[1].start_us);
        assert_eq!(ranges[1].pulse_us(2.0), ranges[1].full_us);

        let mut dead = ramps.clone();
        dead[1].iter_mut().for_each(|s| s.speed_rad_s = 0.0);
        assert!(matches!(
            calibrate_esc(&dead, &EscSettings::default()),
            Err(EscCalError::NeverTurned { output: 1, .. })
        ));
        let short = vec![ramp(1080, 1900, 1910)];
        assert!(matches!(
            calibrate_esc(&short, &EscSettings::default()),
            Err(EscCalError::NoPlateau { output: 0, .. })
        ));
        let mut shuffled = ramps.clone();
        shuffled[0].swap(3, 4);
        assert!(matches!(
            calibrate_esc(&shuffled, &EscSettings::default()),
            Err(EscCalError::NotARamp { index: 4, .. })
        ));
        let late = vec![ramp(1080, 1900, 2000)[30..].to_vec()];
        assert!(matches!(
            calibrate_esc(&late, &EscSettings::default()),
            Err(EscCalError::StartedTurning { .. })
        ));
        let mut stall = ramps;
        stall[0][150].speed_rad_s = 10.0;
        assert!(matches!(
            calibrate_esc(&stall, &EscSettings::default()),
            Err(EscCalError::SpeedFell { output: 0, .. })
        ));
    }
}
