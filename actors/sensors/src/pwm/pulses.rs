//! Actuator commands → ESC pulse widths, through each output's range (`SERVOn_MIN`/`SERVOn_MAX`,
//! [`EscRanges`]), and the command the output thread writes ([`PulseCommand`]).

use kestrel_proto::esc::EscRanges;
use kestrel_proto::messages::{ActuatorOutputs, MAX_MOTORS};

/// Pulse widths and rate (standard PWM ESCs: 1000–2000 µs at 50–490 Hz).
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct PulseConfig {
    /// Pulse repetition rate (Hz).
    pub frequency_hz: f64,
    /// Pulse while disarmed: the ESC sees a signal and keeps the motor stopped (µs).
    pub disarmed_us: u32,
    /// Pulse for command 0 while armed (µs), every output's `SERVOn_MIN` until it is set (an
    /// ESC range calibration sets one per output); above `disarmed_us` to keep props idling.
    pub min_us: u32,
    /// Pulse for command 1 (µs), every output's `SERVOn_MAX` until it is set.
    pub max_us: u32,
}

/// What the output thread writes: a pulse per motor slot (µs), and whether it arms the motors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PulseCommand {
    pub armed: bool,
    pub pulses_us: [u32; MAX_MOTORS],
}

impl PulseCommand {
    /// Every motor at the disarmed pulse.
    pub fn disarmed(config: &PulseConfig) -> PulseCommand {
        PulseCommand { armed: false, pulses_us: [config.disarmed_us; MAX_MOTORS] }
    }

    /// Direct pulses (µs, already checked by `kestrel_proto::esc::DirectPulses`), disarmed.
    pub fn direct(pulses_us: &[f64; MAX_MOTORS]) -> PulseCommand {
        PulseCommand { armed: false, pulses_us: pulses_us.map(|p| p.round() as u32) }
    }
}

impl Default for PulseConfig {
    fn default() -> PulseConfig {
        PulseConfig { frequency_hz: 400.0, disarmed_us: 1000, min_us: 1000, max_us: 2000 }
    }
}

impl PulseConfig {
    /// Checks the pulses fit the period and each other; the error says which value is wrong.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.frequency_hz.is_finite() && self.frequency_hz > 0.0) {
            return Err(format!("frequency_hz must be positive, got {}", self.frequency_hz));
        }
        if !(self.disarmed_us <= self.min_us && self.min_us < self.max_us) {
            return Err(format!(
                "need disarmed_us ≤ min_us < max_us, got {} / {} / {}",
                self.disarmed_us, self.min_us, self.max_us
            ));
        }
        if f64::from(self.max_us) >= self.period_ns() as f64 / 1000.0 {
            return Err(format!("max_us {} does not fit a {} Hz period", self.max_us, self.frequency_hz));
        }
        Ok(())
    }

    /// The PWM period (ns).
    pub fn period_ns(&self) -> u64 {
        (1e9 / self.frequency_hz).round() as u64
    }

    /// Every output on `min_us..max_us`: the ranges before any `SERVOn_*` is set.
    pub fn ranges(&self) -> EscRanges {
        EscRanges::uniform(f64::from(self.min_us), f64::from(self.max_us))
    }
}

/// The pulses (µs) for every motor slot: all at `disarmed_us` unless `outputs.armed`; armed,
/// each command is clamped to 0..1 (a NaN counts as 0) and scaled onto its output's range.
pub fn pulse_widths_us(outputs: &ActuatorOutputs, config: &PulseConfig, ranges: &EscRanges) -> PulseCommand {
    if !outputs.armed {
        return PulseCommand::disarmed(config);
    }
    let mut pulses_us = [config.disarmed_us; MAX_MOTORS];
    for (i, (p, &m)) in pulses_us.iter_mut().zip(&outputs.motors).enumerate() {
        *p = ranges.pulse_us(i, m).round() as u32;
    }
    PulseCommand { armed: true, pulses_us }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kestrel_proto::Time;

    #[test]
    fn disarmed_ignores_commands_and_armed_scales() {
        let config = PulseConfig::default();
        let ranges = config.ranges();
        let mut outputs = ActuatorOutputs { time: Time::ZERO, armed: false, motors: [1.0; MAX_MOTORS] };
        assert_eq!(pulse_widths_us(&outputs, &config, &ranges).pulses_us, [1000; MAX_MOTORS]);
        outputs.armed = true;
        outputs.motors = [0.0, 0.5, 1.0, 1.7, -0.2, f64::NAN, 0.25, 0.0];
        let armed = pulse_widths_us(&outputs, &config, &ranges);
        assert_eq!((armed.armed, armed.pulses_us), (true, [1000, 1500, 2000, 2000, 1000, 1000, 1250, 1000]));
        // A calibrated output maps the same command onto its own range.
        let mut calibrated = ranges;
        calibrated.outputs[1] = kestrel_proto::esc::OutputRange { min_us: 1080.0, max_us: 1920.0 };
        assert_eq!(pulse_widths_us(&outputs, &config, &calibrated).pulses_us[1], 1500);
        outputs.motors[1] = 0.25;
        assert_eq!(pulse_widths_us(&outputs, &config, &calibrated).pulses_us[1], 1290);
    }

    #[test]
    fn validation() {
        assert_eq!(PulseConfig::default().validate(), Ok(()));
        assert_eq!(PulseConfig::default().period_ns(), 2_500_000);
        assert!(
            PulseConfig { frequency_hz: 490.0, max_us: 2100, ..PulseConfig::default() }.validate().is_err()
        );
        assert!(PulseConfig { disarmed_us: 1100, ..PulseConfig::default() }.validate().is_err());
        assert!(PulseConfig { frequency_hz: 0.0, ..PulseConfig::default() }.validate().is_err());
    }
}
