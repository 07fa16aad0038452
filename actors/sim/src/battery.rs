//! A LiPo pack: open-circuit voltage falling with charge drawn, an internal resistance that
//! sags the terminal voltage under load, and a current set by the power the motors draw.
//!
//! The open-circuit voltage is linear from 4.2 V per cell (full) to 3.3 V per cell (empty), a
//! fair straight line through the flat middle of a LiPo curve. Voltage does not feed back into
//! thrust (see `motors`), so hover tests do not drift as the pack drains.

use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, non_negative, positive};

const FULL_CELL_V: f64 = 4.2;
const EMPTY_CELL_V: f64 = 3.3;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BatteryParams {
    /// Rated capacity (mAh).
    pub capacity_mah: f64,
    /// Cells in series.
    pub cells: u32,
    /// Internal resistance of the whole pack (Ω).
    pub internal_resistance_ohm: f64,
    /// Power drawn by the flight computer, radios and cameras, on top of the motors (W).
    pub avionics_power_w: f64,
}

impl Default for BatteryParams {
    /// The thesis's 4S 3300 mAh pack.
    fn default() -> BatteryParams {
        BatteryParams { capacity_mah: 3300.0, cells: 4, internal_resistance_ohm: 0.06, avionics_power_w: 6.0 }
    }
}

impl BatteryParams {
    pub(crate) fn validate(&self) -> Result<(), InvalidParam> {
        positive("capacity_mah", self.capacity_mah)?;
        if self.cells == 0 {
            return Err(InvalidParam::new("cells", "must be at least 1"));
        }
        non_negative("internal_resistance_ohm", self.internal_resistance_ohm)?;
        non_negative("avionics_power_w", self.avionics_power_w)
    }
}

/// What the active faults do to the pack (see [`FaultKind`](crate::faults::FaultKind)).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BatteryFaults {
    /// `battery_sag`: subtracted from the terminal voltage (V); the current is left alone.
    pub sag_v: f64,
}

/// The pack's state.
#[derive(Clone, Debug)]
pub(crate) struct Battery {
    params: BatteryParams,
    consumed_mah: f64,
    voltage_v: f64,
    current_a: f64,
    /// The active sag (V).
    sag_v: f64,
}

impl Battery {
    pub(crate) fn new(params: &BatteryParams) -> Battery {
        let voltage_v = FULL_CELL_V * f64::from(params.cells);
        Battery { params: params.clone(), consumed_mah: 0.0, voltage_v, current_a: 0.0, sag_v: 0.0 }
    }

    /// Applies the battery faults active from now on.
    pub(crate) fn set_faults(&mut self, faults: &BatteryFaults) {
        self.sag_v = faults.sag_v;
    }

    /// Draws `load_power_w` (electrical, motors) plus avionics for `dt_s`.
    ///
    /// Terminal voltage V and current I satisfy V = E − I·R and V·I = P, so
    /// V = (E + √(E² − 4PR)) / 2; past the pack's maximum power the voltage collapses to E/2.
    pub(crate) fn draw(&mut self, load_power_w: f64, dt_s: f64) {
        let power_w = load_power_w + self.params.avionics_power_w;
        let remaining = self.remaining();
        let cell_v = EMPTY_CELL_V + (FULL_CELL_V - EMPTY_CELL_V) * remaining;
        let emf_v = cell_v * f64::from(self.params.cells);
        let r = self.params.internal_resistance_ohm;
        let discriminant = (emf_v * emf_v - 4.0 * power_w * r).max(0.0);
        self.voltage_v = (emf_v + discriminant.sqrt()) / 2.0;
        self.current_a = power_w / self.voltage_v;
        self.consumed_mah += self.current_a * dt_s * 1000.0 / 3600.0;
    }

    /// Remaining charge, 0..1.
    pub(crate) fn remaining(&self) -> f64 {
        (1.0 - self.consumed_mah / self.params.capacity_mah).clamp(0.0, 1.0)
    }

    /// Terminal voltage (V), lowered by an active `battery_sag` (never below 0).
    pub(crate) fn voltage_v(&self) -> f64 {
        (self.voltage_v - self.sag_v).max(0.0)
    }

    pub(crate) fn current_a(&self) -> f64 {
        self.current_a
    }

    pub(crate) fn consumed_mah(&self) -> f64 {
        self.consumed_mah
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn voltage_sags_under_load_and_charge_is_counted() {
        let mut pack = Battery::new(&BatteryParams::default());
        pack.draw(0.0, 1.0);
        let idle_v = pack.voltage_v();
        pack.draw(300.0, 36.0);
        assert!(pack.voltage_v() < idle_v - 1.0, "{} vs {idle_v}", pack.voltage_v());
        // I·R = E − V.
        let sag = (idle_v - pack.voltage_v()) / pack.current_a();
        assert!((sag - 0.06).abs() < 0.01, "{sag}");
        assert!((pack.consumed_mah() - pack.current_a() * 36.0 / 3.6).abs() < 1.0 && pack.remaining() < 0.95);
    }

    #[test]
    fn a_sag_lowers_the_terminal_voltage_by_its_volts_and_no_further_than_zero() {
        let mut pack = Battery::new(&BatteryParams::default());
        pack.draw(200.0, 1.0);
        let (healthy_v, healthy_a) = (pack.voltage_v(), pack.current_a());
        pack.set_faults(&BatteryFaults { sag_v: 1.5 });
        assert_eq!(pack.voltage_v(), healthy_v - 1.5);
        assert_eq!(pack.current_a(), healthy_a);
        pack.set_faults(&BatteryFaults { sag_v: 100.0 });
        assert_eq!(pack.voltage_v(), 0.0);
        pack.set_faults(&BatteryFaults::default());
        assert_eq!(pack.voltage_v(), healthy_v);
    }
}
