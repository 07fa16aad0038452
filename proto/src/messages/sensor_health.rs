//! How a hardware driver is doing: one report per driver actor per second, so a bench or a
//! ground station sees a sensor that slows down, throws errors or clips before it matters.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// One driver's health over the last report window.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct SensorHealth {
    /// End of the window.
    pub time: Time,
    /// The driver actor's name in the config (`gps`, `imu`, `rc`, ...).
    pub sensor: String,
    /// The device it reads: a device node (`/dev/ttyAMA0`) or a sysfs directory.
    pub device: String,
    /// Messages published per second over the window (Hz): fixes, averaged IMU samples, RC
    /// frames.
    pub rate_hz: f64,
    /// Bad input in the window: failed reads, frames with a bad checksum or framing, values
    /// out of range. Each was skipped, none was fatal.
    pub errors: u64,
    /// Bad input since the driver started.
    pub errors_total: u64,
    /// IMU samples in the window with an axis at the end of its full-scale range, so the
    /// average under-reports the motion (0 for other sensors).
    pub clipped: u64,
}
crate::impl_message!(SensorHealth);
