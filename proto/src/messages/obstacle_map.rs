//! The simulated world's obstacles, published once at start so a flight log carries the map the
//! vehicle flew through: `kestrel report` draws the flown path over it (thesis Fig. 3.41–3.42)
//! without reading the world file, which may have changed since the flight.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::geo::Geodetic;
use crate::time::Time;

/// One obstacle's shape and place, in the local NED frame around [`ObstacleMap::home`]: the
/// simulator's world files list them under `[[obstacles]]` with a `kind`, and its map message
/// carries the same. Every one stands on or above flat ground at home's altitude.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Obstacle {
    /// A box turned about the down axis.
    Box {
        /// Centre, north/east/down from home (m); down is negative above ground.
        center_ned_m: [f64; 3],
        /// Full extents along its own north, east, down axes before the yaw (m).
        size_m: [f64; 3],
        /// Rotation about down, clockwise seen from above (degrees).
        #[serde(default)]
        yaw_deg: f64,
    },
    /// A vertical cylinder standing on the ground (a tree).
    Cylinder {
        /// Centre of the base, north/east from home (m).
        base_ne_m: [f64; 2],
        radius_m: f64,
        height_m: f64,
    },
    /// A thin vertical slab standing on the ground between two points.
    Wall {
        /// One end of the wall's centre line, north/east from home (m).
        from_ne_m: [f64; 2],
        /// The other end (m).
        to_ne_m: [f64; 2],
        height_m: f64,
        thickness_m: f64,
        /// Whether its faces carry texture for stereo matching; a plain wall is the case the
        /// thesis's avoider missed (§4.2.3), so plots tell the two apart. For the stereo
        /// renderer; physics ignores it. Textured unless a world file says otherwise.
        #[serde(default = "textured_by_default")]
        textured: bool,
    },
}

fn textured_by_default() -> bool {
    true
}

/// Every obstacle of the world as loaded (including any generated at load time), with the
/// home that anchors their coordinates.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ObstacleMap {
    /// When the simulator published the map (its start time).
    pub time: Time,
    /// Origin of the NED frame the obstacles are given in; the ground is flat at its altitude.
    pub home: Geodetic,
    /// Empty for a world without obstacles.
    pub obstacles: Vec<Obstacle>,
}
crate::impl_message!(ObstacleMap);
