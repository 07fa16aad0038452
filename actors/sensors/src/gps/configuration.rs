//! The UBX messages that set a u-blox receiver up for flight, in the order they are sent.
//!
//! A u-blox M8 powers up at 9600 baud speaking NMEA. The first message (CFG-PRT) is sent at
//! that rate and moves the UART to the flight rate with UBX output only (NMEA would repeat
//! each solution in five sentences for nothing); the rest are sent at the new rate: the
//! measurement rate (CFG-RATE), the dynamic platform model (CFG-NAV5), and NAV-PVT once per
//! solution (CFG-MSG). Nothing is saved to the receiver's flash: the driver configures it on
//! every start, as PX4 and ArduPilot do. Receivers that are not u-blox ignore all of this and
//! must be read unconfigured at their own rate (the NMEA fallback).

use crate::ubx::{DynamicModel, cfg_msg, cfg_nav5, cfg_prt_uart, cfg_rate, config};

/// The receiver's UART1 (the one wired to the flight computer on M8N modules).
const UART1: u8 = 1;

/// Why a configuration cannot be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ConfigurationError {
    #[error("GPS rate_hz must give a measurement period of 25..=65535 ms, got {0} Hz")]
    Rate(f64),
}

/// The set-up messages: `switch_baud` goes out at the receiver's current baud rate, `settings`
/// at the new one.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Configuration {
    pub switch_baud: Vec<u8>,
    pub settings: Vec<Vec<u8>>,
}

impl Configuration {
    /// Messages for `baud` (bit/s), one solution every `1 / rate_hz` s, and `model`.
    /// u-blox M8 receivers accept measurement periods of 25 ms (40 Hz) and up.
    pub fn new(baud: u32, rate_hz: f64, model: DynamicModel) -> Result<Configuration, ConfigurationError> {
        let period_ms = (1000.0 / rate_hz).round();
        if !(rate_hz.is_finite() && (25.0..=65_535.0).contains(&period_ms)) {
            return Err(ConfigurationError::Rate(rate_hz));
        }
        let switch_baud =
            cfg_prt_uart(UART1, baud, config::PROTO_UBX | config::PROTO_NMEA, config::PROTO_UBX);
        let nav_pvt = cfg_msg(crate::ubx::nav_pvt::CLASS, crate::ubx::nav_pvt::ID, 1);
        Ok(Configuration {
            settings: vec![switch_baud.clone(), cfg_rate(period_ms as u16), cfg_nav5(model), nav_pvt],
            switch_baud,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ubx::UbxParser;

    #[test]
    fn five_hz_airborne_at_115200() {
        let c = Configuration::new(115_200, 5.0, DynamicModel::Airborne2g).expect("valid");
        let mut parser = UbxParser::new();
        parser.push(&c.settings.concat());
        let frames: Vec<_> = std::iter::from_fn(|| parser.next_frame()).collect();
        let ids: Vec<(u8, u8)> = frames.iter().map(|f| (f.class, f.id)).collect();
        assert_eq!(ids, [(0x06, 0x00), (0x06, 0x08), (0x06, 0x24), (0x06, 0x01)]);
        assert_eq!(&frames[0].payload[8..12], &115_200u32.to_le_bytes());
        assert_eq!(&frames[0].payload[12..16], &[0x03, 0x00, 0x01, 0x00], "UBX and NMEA in, UBX out");
        assert_eq!(&frames[1].payload[0..2], &200u16.to_le_bytes());
        assert_eq!(frames[2].payload[2], 7, "dynModel 7: airborne < 2 g");
        assert_eq!(frames[3].payload, [0x01, 0x07, 0x01]);
        assert_eq!(c.switch_baud, c.settings[0]);
    }

    #[test]
    fn impossible_rates_are_refused() {
        for hz in [0.0, -5.0, 50.0, f64::NAN] {
            let result = Configuration::new(115_200, hz, DynamicModel::Airborne1g);
            assert!(matches!(result, Err(ConfigurationError::Rate(_))), "{hz}");
        }
    }
}
