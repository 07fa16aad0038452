use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// A 3-axis magnetometer sample in the body FRD frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct MagSample {
    /// Measurement time.
    pub time: Time,
    /// Magnetic flux density along body forward, right, down (gauss).
    pub field_gauss: [f64; 3],
}
crate::impl_message!(MagSample);
