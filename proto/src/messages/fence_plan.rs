//! The geofence a ground station uploaded (MAVLink's MISSION_TYPE_FENCE): inclusion and
//! exclusion polygons and circles, in WGS-84, enforced by the commander beside the vehicle's
//! own cylinder. The link sends one when an upload completes (checked whole, as ArduPilot's
//! `AC_PolyFence_loader::validate_fence`) and an empty one when the fence is cleared.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// Whether the vehicle must stay inside a zone or out of it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum FenceKind {
    /// The vehicle must stay inside (every inclusion zone at once, as ArduCopter).
    Inclusion,
    /// The vehicle must stay out.
    Exclusion,
}

/// One zone of an uploaded fence.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum FenceZone {
    /// A polygon of at least 3 `[lat_deg, lon_deg]` vertices, closed from the last to the first.
    Polygon { kind: FenceKind, vertices_deg: Vec<[f64; 2]> },
    /// A circle of `radius_m` (m, > 0) around `center_deg` (`[lat_deg, lon_deg]`).
    Circle { kind: FenceKind, center_deg: [f64; 2], radius_m: f64 },
}

/// A whole uploaded fence; it replaces the one before, and no zones clears it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct FencePlan {
    pub time: Time,
    pub zones: Vec<FenceZone>,
}
crate::impl_message!(FencePlan);
