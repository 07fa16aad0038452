//! The GPS driver: [`decoder`] turns a receiver's serial bytes into fixes (UBX NAV-PVT, NMEA
//! fallback), [`configuration`] builds the UBX set-up sequence; the actor shell is
//! [`crate::gps_actor`].

pub mod configuration;
pub mod decoder;

pub use configuration::{Configuration, ConfigurationError};
pub use decoder::{GpsDecoder, GpsStats, NMEA_FALLBACK_AFTER};
