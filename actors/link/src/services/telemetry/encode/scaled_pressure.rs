//! SCALED_PRESSURE: the barometer's static pressure (hPa) and temperature (cdegC), as ArduPilot
//! sends its first barometer.

use kestrel_proto::messages::BaroSample;
use mavlink::dialects::ardupilotmega::SCALED_PRESSURE_DATA;

/// SCALED_PRESSURE from the barometer's newest `sample`, stamped with its measurement time; no
/// differential pressure sensor (0, as ArduPilot without an airspeed sensor).
pub fn scaled_pressure(sample: &BaroSample) -> SCALED_PRESSURE_DATA {
    SCALED_PRESSURE_DATA {
        time_boot_ms: (sample.time.as_micros() / 1000) as u32,
        press_abs: (sample.pressure_pa / 100.0) as f32,
        press_diff: 0.0,
        temperature: (sample.temperature_c * 100.0).round().clamp(f64::from(i16::MIN), f64::from(i16::MAX))
            as i16,
        temperature_press_diff: 0,
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::Time;

    use super::*;

    #[test]
    fn pascals_go_out_as_hectopascals_and_degrees_as_centidegrees() {
        let p = scaled_pressure(&BaroSample {
            time: Time::from_micros(2_500_000),
            pressure_pa: 101_083.5,
            altitude_m: 20.0,
            temperature_c: 34.81,
        });
        assert!((p.press_abs - 1010.835).abs() < 1e-3, "{p:?}");
        assert_eq!((p.temperature, p.time_boot_ms, p.press_diff), (3481, 2500, 0.0));
    }
}
