//! What the stereo camera sees ahead, summarised for the obstacle avoider (thesis §3.3.1–3.3.3)
//! and for flight controllers that take MAVLink's `OBSTACLE_DISTANCE`.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// Number of `OBSTACLE_DISTANCE` sectors (MAVLink's fixed array length).
pub const OBSTACLE_SECTORS: usize = 72;

/// `OBSTACLE_DISTANCE` value of a sector with no information (MAVLink's `UINT16_MAX`).
pub const SECTOR_UNKNOWN: u16 = u16::MAX;

/// One region of the depth image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct GridRegion {
    /// Share of the region's *valid* pixels nearer than [`DepthGrid::threshold_m`], 0..1: the
    /// thesis's normalised depth value with DESIGN.md's correction (a near pixel is an
    /// obstacle). 0 when the region has no valid pixel.
    pub near_share: f32,
    /// Share of all the region's pixels without a disparity (no texture, occlusion, out of
    /// range), 0..1. A mostly-invalid region may hide a textureless wall (thesis §4.2.3).
    pub invalid_share: f32,
    /// Nearest depth of the region along the camera's optical axis (m): a low percentile of
    /// its valid pixels' depths (2 % by default), so a speckle of wrong disparities cannot
    /// define it; `None` when the region has no valid pixel.
    pub nearest_m: Option<f32>,
}

/// Obstacle distances around the vehicle, laid out as MAVLink's `OBSTACLE_DISTANCE`
/// (body frame FRD; angles clockwise from forward, seen from above).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ObstacleSectors {
    /// Horizontal distance to the nearest obstacle per sector (cm), always
    /// [`OBSTACLE_SECTORS`] long. Sector `i` is centred on `angle_offset_deg + i ·
    /// increment_deg`. [`SECTOR_UNKNOWN`] outside the camera's field of view or where no pixel
    /// had a disparity; `max_distance_cm + 1` where the sector is free up to `max_distance_cm`.
    pub distances_cm: Vec<u16>,
    /// Angular width of each sector (deg).
    pub increment_deg: f32,
    /// Centre angle of sector 0, clockwise from the body's forward axis (deg).
    pub angle_offset_deg: f32,
    /// Nearest distance the sensor reports (cm).
    pub min_distance_cm: u16,
    /// Farthest distance the sensor reports (cm).
    pub max_distance_cm: u16,
}

impl ObstacleSectors {
    /// The range (m) of the obstacle sector `index` reports, `None` when it reports none: no
    /// information ([`SECTOR_UNKNOWN`]), free up to `max_distance_cm`, below the sensor's
    /// `min_distance_cm`, or no such sector.
    pub fn obstacle_m(&self, index: usize) -> Option<f64> {
        let cm = *self.distances_cm.get(index)?;
        (cm != SECTOR_UNKNOWN && (self.min_distance_cm..=self.max_distance_cm).contains(&cm))
            .then(|| f64::from(cm) / 100.0)
    }

    /// The centre bearing of sector `index` (deg, clockwise from forward), wrapped to −180..180.
    pub fn bearing_deg(&self, index: usize) -> f64 {
        let deg = f64::from(self.angle_offset_deg) + index as f64 * f64::from(self.increment_deg);
        (deg + 180.0).rem_euclid(360.0) - 180.0
    }
}

/// The depth image of one stereo frame split into 3×3 regions (thesis Figure 3.29).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct DepthGrid {
    /// Capture time of the stereo frame the grid was computed from.
    pub time: Time,
    /// Sequence number of that frame at its source.
    pub frame_sequence: u64,
    /// Depth below which a valid pixel counts as near (m); the thesis uses 5 m.
    pub threshold_m: f32,
    /// Regions as `[row][column]` of the image: row 0 is the top (up), column 0 the left,
    /// so `regions[1][1]` is the thesis's centre region `D_cc` and `regions[0][2]` is `D_ru`.
    pub regions: [[GridRegion; 3]; 3],
    /// The same depth image as `OBSTACLE_DISTANCE` sectors.
    pub sectors: ObstacleSectors,
}
crate::impl_message!(DepthGrid);
