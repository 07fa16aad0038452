use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// Battery state as a power module reports it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct BatteryStatus {
    /// Measurement time.
    pub time: Time,
    /// Terminal voltage under load (V).
    pub voltage_v: f64,
    /// Current drawn (A, positive when discharging).
    pub current_a: f64,
    /// Charge drawn since start (mAh).
    pub consumed_mah: f64,
    /// Remaining charge, 0..1.
    pub remaining: f64,
}
crate::impl_message!(BatteryStatus);
