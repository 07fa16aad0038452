//! The barometer: static pressure of the ISA standard atmosphere at the vehicle's altitude,
//! with white noise, and the pressure altitude computed back from the noisy pressure.

use kestrel_proto::Time;
use kestrel_proto::messages::BaroSample;
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, finite, non_negative, rate};
use crate::sensors::noise::standard_normal;

/// ISA sea-level pressure (Pa).
const SEA_LEVEL_PA: f64 = 101_325.0;
/// ISA sea-level temperature (°C).
const SEA_LEVEL_C: f64 = 15.0;
/// ISA tropospheric lapse rate (K/m).
const LAPSE_K_M: f64 = 0.0065;
/// Lapse rate over sea-level temperature (1/m).
const LAPSE_OVER_T0: f64 = LAPSE_K_M / 288.15;
/// g·M/(R·L) for the troposphere.
const EXPONENT: f64 = 5.255_88;

/// Static pressure at `altitude_msl_m` in the ISA troposphere (Pa).
pub fn isa_pressure_pa(altitude_msl_m: f64) -> f64 {
    SEA_LEVEL_PA * (1.0 - LAPSE_OVER_T0 * altitude_msl_m).powf(EXPONENT)
}

/// Pressure altitude of `pressure_pa` in the ISA troposphere (m).
pub fn isa_altitude_m(pressure_pa: f64) -> f64 {
    (1.0 - (pressure_pa / SEA_LEVEL_PA).powf(1.0 / EXPONENT)) / LAPSE_OVER_T0
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BaroParams {
    /// Sample rate (Hz).
    pub rate_hz: f64,
    /// Delay from measurement to delivery (s).
    pub lag_s: f64,
    /// 1σ white noise of the pressure (Pa); about 12 Pa per metre near sea level.
    pub pressure_noise_pa: f64,
    /// Sensor temperature above the ISA air temperature, from the board's own heat (°C).
    pub temperature_offset_c: f64,
}

impl Default for BaroParams {
    /// MS5611 at 10 Hz with the thesis's 50 ms lag; 3 Pa ≈ 0.25 m including prop wash.
    fn default() -> BaroParams {
        BaroParams { rate_hz: 10.0, lag_s: 0.05, pressure_noise_pa: 3.0, temperature_offset_c: 5.0 }
    }
}

impl BaroParams {
    pub(crate) fn validate(&self) -> Result<(), InvalidParam> {
        rate("rate_hz", self.rate_hz)?;
        non_negative("lag_s", self.lag_s)?;
        if self.lag_s > 10.0 {
            return Err(InvalidParam::new("lag_s", "must not exceed 10 s"));
        }
        non_negative("pressure_noise_pa", self.pressure_noise_pa)?;
        finite("temperature_offset_c", &[self.temperature_offset_c])
    }
}

/// What the active faults do to the barometer (see [`FaultKind`](crate::faults::FaultKind)).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BaroFaults {
    /// `baro_drift`: added to the altitude the pressure is computed at (m, up positive), so the
    /// pressure and the pressure altitude agree.
    pub altitude_error_m: f64,
    /// `baro_stuck`: the last sample repeated.
    pub stuck: bool,
}

/// The barometer's random stream and its last sample.
#[derive(Clone, Debug)]
pub(crate) struct Baro {
    params: BaroParams,
    rng: Pcg64,
    last: Option<BaroSample>,
}

impl Baro {
    pub(crate) fn new(params: &BaroParams, rng: Pcg64) -> Baro {
        Baro { params: params.clone(), rng, last: None }
    }

    /// A sample at `time` with the vehicle at `altitude_msl_m`, as `faults` leave it. The
    /// noise is drawn whatever the faults, so the stream after a fault is the same as without.
    pub(crate) fn measure(&mut self, time: Time, altitude_msl_m: f64, faults: &BaroFaults) -> BaroSample {
        let reads_at_m = altitude_msl_m + faults.altitude_error_m;
        let pressure_pa =
            isa_pressure_pa(reads_at_m) + standard_normal(&mut self.rng) * self.params.pressure_noise_pa;
        let sample = BaroSample {
            time,
            pressure_pa,
            altitude_m: isa_altitude_m(pressure_pa),
            temperature_c: SEA_LEVEL_C - LAPSE_K_M * altitude_msl_m + self.params.temperature_offset_c,
        };
        match &self.last {
            Some(last) if faults.stuck => BaroSample { time, ..last.clone() },
            _ => {
                self.last = Some(sample.clone());
                sample
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn isa_matches_published_table_and_inverts() {
        // ISA tables: 1000 m → 89 875 Pa, 20 m → 101 085 Pa.
        assert!((isa_pressure_pa(1000.0) - 89_875.0).abs() < 5.0);
        assert!((isa_pressure_pa(20.0) - 101_085.0).abs() < 2.0);
        assert!((isa_altitude_m(isa_pressure_pa(123.4)) - 123.4).abs() < 1e-6);
    }
}
