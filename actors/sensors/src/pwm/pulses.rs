//! Actuator commands → ESC pulse widths.

use kestrel_proto::messages::{ActuatorOutputs, MAX_MOTORS};

/// Pulse widths and rate (standard PWM ESCs: 1000–2000 µs at 50–490 Hz).
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct PulseConfig {
    /// Pulse repetition rate (Hz).
    pub frequency_hz: f64,
    /// Pulse while disarmed: the ESC sees a signal and keeps the motor stopped (µs).
    pub disarmed_us: u32,
    /// Pulse for command 0 while armed (µs); above `disarmed_us` to keep props idling.
    pub min_us: u32,
    /// Pulse for command 1 (µs).
    pub max_us: u32,
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
}

/// Pulse widths (µs) for every motor slot: all at `disarmed_us` unless `outputs.armed`;
/// armed, each command is clamped to 0..1 (a NaN counts as 0) and scaled onto
/// `min_us..max_us`.
pub fn pulse_widths_us(outputs: &ActuatorOutputs, config: &PulseConfig) -> [u32; MAX_MOTORS] {
    if !outputs.armed {
        return [config.disarmed_us; MAX_MOTORS];
    }
    let span = f64::from(config.max_us - config.min_us);
    outputs.motors.map(|m| {
        let command = if m.is_nan() { 0.0 } else { m.clamp(0.0, 1.0) };
        config.min_us + (command * span).round() as u32
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use kestrel_proto::Time;

    #[test]
    fn disarmed_ignores_commands_and_armed_scales() {
        let config = PulseConfig::default();
        let mut outputs = ActuatorOutputs { time: Time::ZERO, armed: false, motors: [1.0; MAX_MOTORS] };
        assert_eq!(pulse_widths_us(&outputs, &config), [1000; MAX_MOTORS]);
        outputs.armed = true;
        outputs.motors = [0.0, 0.5, 1.0, 1.7, -0.2, f64::NAN, 0.25, 0.0];
        assert_eq!(pulse_widths_us(&outputs, &config), [1000, 1500, 2000, 2000, 1000, 1000, 1250, 1000]);
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
