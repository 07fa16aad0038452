use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// A barometer sample.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct BaroSample {
    /// Measurement time (the end of the conversion, before any bus or filter lag).
    pub time: Time,
    /// Static pressure (Pa).
    pub pressure_pa: f64,
    /// Pressure altitude above mean sea level in the ISA standard atmosphere (m).
    pub altitude_m: f64,
    /// Sensor temperature (°C).
    pub temperature_c: f64,
}
crate::impl_message!(BaroSample);
