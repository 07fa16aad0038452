//! Temperature and pressure from the raw conversions, in the datasheet's integer arithmetic
//! (MS5611-01BA03 datasheet, "Pressure and temperature calculation" and "Second order
//! temperature compensation"). Divisions by 2ⁿ are arithmetic shifts (rounding towards −∞),
//! as in the reference drivers (PX4, ArduPilot, Linux `ms5611_core.c`).

use crate::ms5611::prom::Prom;

/// The compensated reading.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Compensated {
    /// Temperature (0.01 °C): 2007 = 20.07 °C.
    pub temperature_centi_c: i32,
    /// Pressure (0.01 mbar = 1 Pa): 100009 = 1000.09 mbar.
    pub pressure_pa: i32,
}

impl Compensated {
    /// Temperature (°C).
    pub fn temperature_c(&self) -> f64 {
        f64::from(self.temperature_centi_c) / 100.0
    }
}

/// Compensates raw pressure `d1` and raw temperature `d2` (24-bit ADC values) with `prom`,
/// applying the second-order correction below 20 °C and its extra term below −15 °C.
pub fn compensate(prom: &Prom, d1: u32, d2: u32) -> Compensated {
    let c = |i| i64::from(prom.c(i));
    let (d1, d2) = (i64::from(d1), i64::from(d2));
    // First order.
    let dt = d2 - (c(5) << 8);
    let mut temp = 2000 + ((dt * c(6)) >> 23);
    let mut off = (c(2) << 16) + ((c(4) * dt) >> 7);
    let mut sens = (c(1) << 15) + ((c(3) * dt) >> 8);
    // Second order.
    if temp < 2000 {
        let t2 = (dt * dt) >> 31;
        let cold = (temp - 2000) * (temp - 2000);
        let mut off2 = (5 * cold) >> 1;
        let mut sens2 = (5 * cold) >> 2;
        if temp < -1500 {
            let very_cold = (temp + 1500) * (temp + 1500);
            off2 += 7 * very_cold;
            sens2 += (11 * very_cold) >> 1;
        }
        temp -= t2;
        off -= off2;
        sens -= sens2;
    }
    let pressure = (((d1 * sens) >> 21) - off) >> 15;
    Compensated {
        temperature_centi_c: temp.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32,
        pressure_pa: pressure.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ms5611::prom::tests::datasheet_prom_words;

    fn prom() -> Prom {
        Prom::new(datasheet_prom_words()).expect("valid PROM")
    }

    #[test]
    fn the_datasheet_example() {
        // Datasheet "Pressure and temperature calculation", typical values column.
        let reading = compensate(&prom(), 9_085_466, 8_569_150);
        assert_eq!(reading, Compensated { temperature_centi_c: 2007, pressure_pa: 100_009 });
        assert!((reading.temperature_c() - 20.07).abs() < 1e-12);
    }

    #[test]
    fn second_order_below_20_c() {
        // dT = −566784 → first-order TEMP = 87, T2 = 149, OFF2 = 9 148 922, SENS2 = 4 574 461
        // (worked by hand from the datasheet's formulas).
        let reading = compensate(&prom(), 9_085_466, 8_000_000);
        assert_eq!(reading, Compensated { temperature_centi_c: -62, pressure_pa: 95_989 });
    }

    #[test]
    fn second_order_below_minus_15_c() {
        let reading = compensate(&prom(), 9_085_466, 7_000_000);
        assert_eq!(reading, Compensated { temperature_centi_c: -4431, pressure_pa: 85_693 });
    }
}
