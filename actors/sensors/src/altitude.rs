//! Pressure altitude in the ISA standard atmosphere (troposphere), the same formula family as
//! the simulator's barometer (`kestrel-sim`'s `sensors::baro`), so hardware and simulation
//! report the same altitude for the same pressure.

/// ISA sea-level pressure (Pa).
pub const SEA_LEVEL_PA: f64 = 101_325.0;
/// ISA sea-level temperature (K).
const SEA_LEVEL_K: f64 = 288.15;
/// ISA tropospheric lapse rate (K/m).
const LAPSE_K_M: f64 = 0.0065;
/// g·M/(R·L) for the troposphere (dimensionless).
const EXPONENT: f64 = 5.255_88;

/// Pressure altitude above mean sea level of `pressure_pa` in the ISA troposphere (m).
pub fn isa_altitude_m(pressure_pa: f64) -> f64 {
    (1.0 - (pressure_pa / SEA_LEVEL_PA).powf(1.0 / EXPONENT)) * SEA_LEVEL_K / LAPSE_K_M
}

/// Static pressure at `altitude_msl_m` in the ISA troposphere (Pa).
pub fn isa_pressure_pa(altitude_msl_m: f64) -> f64 {
    SEA_LEVEL_PA * (1.0 - LAPSE_K_M / SEA_LEVEL_K * altitude_msl_m).powf(EXPONENT)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_the_isa_table() {
        assert!(isa_altitude_m(SEA_LEVEL_PA).abs() < 1e-9);
        // ISA table (ICAO Doc 7488): 1000 m → 898.76 hPa, 5000 m → 540.20 hPa.
        assert!((isa_altitude_m(89_876.0) - 1000.0).abs() < 0.5);
        assert!((isa_altitude_m(54_020.0) - 5000.0).abs() < 1.0);
    }

    #[test]
    fn pressure_and_altitude_invert_each_other() {
        for alt in [-400.0, 0.0, 20.0, 1234.5, 8000.0] {
            assert!((isa_altitude_m(isa_pressure_pa(alt)) - alt).abs() < 1e-6);
        }
    }
}
