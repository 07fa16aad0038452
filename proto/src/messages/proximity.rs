//! Obstacle distances all round the vehicle, for a flight controller's proximity library
//! (MAVLink `OBSTACLE_DISTANCE`, BODY_FRD): what the camera sees now plus what it saw and
//! no longer sees, rotated into the body frame at the capture instant.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::messages::ObstacleSectors;
use crate::time::Time;

/// Full-surround obstacle sectors (72 × 5°, FRD, clockwise from forward; cm).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Proximity {
    /// Capture time of the stereo frame behind the sectors: the instant whose body frame
    /// they are expressed in (`OBSTACLE_DISTANCE.time_usec`).
    pub time: Time,
    /// Sequence number of that frame at its source.
    pub frame_sequence: u64,
    /// The sectors: [`SECTOR_UNKNOWN`](crate::messages::SECTOR_UNKNOWN) where neither the
    /// camera nor the obstacle memory says anything, `max_distance_cm + 1` where the camera
    /// sees free space and nothing is remembered, else the nearest obstacle's horizontal range.
    pub sectors: ObstacleSectors,
    /// Sectors whose reading comes from the obstacle memory (nearer than, or outside, what
    /// the camera sees now).
    pub remembered_sectors: u8,
}
crate::impl_message!(Proximity);
