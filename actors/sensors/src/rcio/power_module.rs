//! Battery voltage and current from an analog power module on two ADC channels.
//!
//! The module divides the battery voltage down and turns the current into a voltage through
//! a shunt amplifier: battery V = pin V × `voltage_divider`, A = (pin V − `current_offset_v`) ×
//! `amps_per_volt`. Navio2 wires its POWER port to ADC channels 2 (voltage) and 3 (current);
//! the defaults are ArduPilot's for Navio2 (divider 11.3) and the common 3DR-style module
//! (17 A/V), to be calibrated against a meter for a given module. Charge drawn is the current
//! integrated over time; what is left is the fraction of the pack's capacity not yet drawn.

use kestrel_proto::Time;
use kestrel_proto::messages::BatteryStatus;

/// Which ADC channels the module is on and how to scale them.
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct PowerModule {
    /// ADC channel of the voltage sense (Navio2: 2).
    pub voltage_channel: usize,
    /// ADC channel of the current sense (Navio2: 3).
    pub current_channel: usize,
    /// Battery volts per volt at the pin.
    pub voltage_divider: f64,
    /// Amps per volt at the pin above the offset.
    pub amps_per_volt: f64,
    /// Pin voltage at zero current (V).
    pub current_offset_v: f64,
    /// The pack's capacity (mAh).
    pub capacity_mah: f64,
}

impl Default for PowerModule {
    fn default() -> PowerModule {
        PowerModule {
            voltage_channel: 2,
            current_channel: 3,
            voltage_divider: 11.3,
            amps_per_volt: 17.0,
            current_offset_v: 0.0,
            capacity_mah: 5000.0,
        }
    }
}

/// Integrates the current into charge drawn.
#[derive(Clone, Debug)]
pub struct BatteryMonitor {
    module: PowerModule,
    consumed_mah: f64,
    last: Option<Time>,
}

impl BatteryMonitor {
    pub fn new(module: PowerModule) -> BatteryMonitor {
        BatteryMonitor { module, consumed_mah: 0.0, last: None }
    }

    /// The battery's state from the two pins' readings (mV) taken at `time`.
    pub fn update(&mut self, voltage_pin_mv: u32, current_pin_mv: u32, time: Time) -> BatteryStatus {
        let m = &self.module;
        let voltage_v = f64::from(voltage_pin_mv) / 1000.0 * m.voltage_divider;
        let current_a =
            ((f64::from(current_pin_mv) / 1000.0 - m.current_offset_v) * m.amps_per_volt).max(0.0);
        if let Some(last) = self.last {
            let hours = time.saturating_since(last).as_secs_f64() / 3600.0;
            self.consumed_mah += current_a * hours * 1000.0;
        }
        self.last = Some(time);
        let remaining = if m.capacity_mah > 0.0 {
            (1.0 - self.consumed_mah / m.capacity_mah).clamp(0.0, 1.0)
        } else {
            0.0
        };
        BatteryStatus { time, voltage_v, current_a, consumed_mah: self.consumed_mah, remaining }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scales_the_pins_and_integrates_the_charge() {
        let mut monitor = BatteryMonitor::new(PowerModule::default());
        // 1.100 V at the voltage pin: 12.43 V; 0.588 V at the current pin: 9.996 A.
        let first = monitor.update(1100, 588, Time::from_micros(1_000_000));
        assert!((first.voltage_v - 12.43).abs() < 1e-9 && (first.current_a - 9.996).abs() < 1e-9);
        assert_eq!((first.consumed_mah, first.remaining), (0.0, 1.0));
        // 36 s at 9.996 A: 99.96 mAh of 5000.
        let later = monitor.update(1100, 588, Time::from_micros(37_000_000));
        assert!((later.consumed_mah - 99.96).abs() < 1e-9, "{later:?}");
        assert!((later.remaining - (1.0 - 99.96 / 5000.0)).abs() < 1e-12);
    }
}
