//! The depth grid (thesis §3.3.1–3.3.3 with DESIGN.md's correction): the depth image split
//! into 3×3 regions, each summarised by its share of near pixels, its share of pixels without
//! a depth and its nearest depth; and the same depth as `OBSTACLE_DISTANCE` sectors.
//!
//! The camera is assumed to look along the body's forward axis, image right = body right,
//! image down = body down (FRD); a mounting rotation is not modelled.

use kestrel_proto::Time;
use kestrel_proto::messages::{DepthGrid, GridRegion, OBSTACLE_SECTORS, ObstacleSectors, SECTOR_UNKNOWN};
use serde::{Deserialize, Serialize};

use crate::depth::{DepthMap, StereoGeometry};
use crate::error::VisionError;

/// Width of one `OBSTACLE_DISTANCE` sector (deg): 72 sectors cover the full circle.
pub const SECTOR_DEG: f32 = 360.0 / OBSTACLE_SECTORS as f32;

/// How the depth image is summarised.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GridParams {
    /// A valid pixel nearer than this is an obstacle (m); the thesis uses 5 m (max speed 5 m/s
    /// × 1 s).
    pub threshold_m: f32,
    /// Where the left|centre and centre|right columns meet, as fractions of the image width.
    pub column_edges: [f32; 2],
    /// Where the up|centre and centre|down rows meet, as fractions of the image height.
    pub row_edges: [f32; 2],
    /// Nearest distance the sectors report (cm).
    pub min_distance_cm: u16,
    /// Farthest distance the sectors report (cm); beyond it a sector reads "free".
    pub max_distance_cm: u16,
}

impl Default for GridParams {
    /// Thirds of the image (thesis Figure 3.29), 5 m threshold, sectors 0.3–20 m (the ZED's
    /// range).
    fn default() -> Self {
        GridParams {
            threshold_m: 5.0,
            column_edges: [1.0 / 3.0, 2.0 / 3.0],
            row_edges: [1.0 / 3.0, 2.0 / 3.0],
            min_distance_cm: 30,
            max_distance_cm: 2000,
        }
    }
}

impl GridParams {
    /// Rejects a threshold or layout that cannot be used.
    pub fn check(&self) -> Result<(), VisionError> {
        if !(self.threshold_m.is_finite() && self.threshold_m > 0.0) {
            return Err(VisionError::Params(format!(
                "grid threshold {} m must be positive",
                self.threshold_m
            )));
        }
        for (what, [a, b]) in [("column_edges", self.column_edges), ("row_edges", self.row_edges)] {
            if !(0.0 < a && a < b && b < 1.0) {
                return Err(VisionError::Params(format!(
                    "{what} [{a}, {b}] must satisfy 0 < first < second < 1"
                )));
            }
        }
        if self.min_distance_cm >= self.max_distance_cm || self.max_distance_cm == SECTOR_UNKNOWN {
            return Err(VisionError::Params(format!(
                "sector range {}..{} cm must be increasing and below {SECTOR_UNKNOWN}",
                self.min_distance_cm, self.max_distance_cm
            )));
        }
        Ok(())
    }
}

/// Which of the three bands each of `n` pixels falls in, given the two edge fractions.
fn bands(n: usize, edges: [f32; 2]) -> Vec<usize> {
    let cut = |f: f32| (f * n as f32).round() as usize;
    let (a, b) = (cut(edges[0]), cut(edges[1]));
    (0..n).map(|i| usize::from(i >= a) + usize::from(i >= b)).collect()
}

/// The grid of `depth` (captured at `time`, frame `frame_sequence`), whose pixels follow
/// `geometry`. The sectors take the nearest horizontal range of the centre row band (the
/// vehicle's own level), so the ground and the sky above do not read as obstacles.
pub fn depth_grid(
    depth: &DepthMap,
    geometry: &StereoGeometry,
    params: &GridParams,
    time: Time,
    frame_sequence: u64,
) -> DepthGrid {
    let (cols, rows) = (bands(depth.width, params.column_edges), bands(depth.height, params.row_edges));
    // Per image column: its sector and the factor turning depth Z into horizontal range.
    let columns: Vec<(usize, f32)> = (0..depth.width)
        .map(|u| {
            let tan = (u as f64 - geometry.cx_px) / geometry.focal_px;
            let azimuth_deg = tan.atan().to_degrees() as f32;
            let sector = (azimuth_deg / SECTOR_DEG).round().rem_euclid(OBSTACLE_SECTORS as f32) as usize;
            (sector % OBSTACLE_SECTORS, (1.0 + tan * tan).sqrt() as f32)
        })
        .collect();

    let mut counts = [[RegionCount::default(); 3]; 3];
    let mut in_view = [false; OBSTACLE_SECTORS];
    let mut seen = [false; OBSTACLE_SECTORS];
    let mut nearest_range = [f32::INFINITY; OBSTACLE_SECTORS];
    for &(sector, _) in &columns {
        in_view[sector] = true;
    }
    for (y, row) in depth.values.chunks_exact(depth.width.max(1)).enumerate() {
        let band = rows[y];
        let cells = &mut counts[band];
        for (x, &z) in row.iter().enumerate() {
            let cell = &mut cells[cols[x]];
            cell.total += 1;
            if z.is_nan() {
                cell.invalid += 1;
                continue;
            }
            cell.near += u32::from(z < params.threshold_m);
            cell.nearest = cell.nearest.min(z);
            if band == 1 {
                let (sector, range_factor) = columns[x];
                seen[sector] = true;
                nearest_range[sector] = nearest_range[sector].min(z * range_factor);
            }
        }
    }

    let regions = counts.map(|row| row.map(RegionCount::region));
    let max_cm = params.max_distance_cm;
    let distances_cm = (0..OBSTACLE_SECTORS)
        .map(|s| match (in_view[s], seen[s]) {
            (true, true) => {
                let cm = (nearest_range[s] * 100.0).round();
                if cm > f32::from(max_cm) { max_cm + 1 } else { cm.max(0.0) as u16 }
            }
            _ => SECTOR_UNKNOWN,
        })
        .collect();
    DepthGrid {
        time,
        frame_sequence,
        threshold_m: params.threshold_m,
        regions,
        sectors: ObstacleSectors {
            distances_cm,
            increment_deg: SECTOR_DEG,
            angle_offset_deg: 0.0,
            min_distance_cm: params.min_distance_cm,
            max_distance_cm: max_cm,
        },
    }
}

#[derive(Clone, Copy)]
struct RegionCount {
    total: u32,
    invalid: u32,
    near: u32,
    nearest: f32,
}

impl Default for RegionCount {
    fn default() -> Self {
        RegionCount { total: 0, invalid: 0, near: 0, nearest: f32::INFINITY }
    }
}

impl RegionCount {
    fn region(self) -> GridRegion {
        let valid = self.total - self.invalid;
        GridRegion {
            near_share: if valid > 0 { self.near as f32 / valid as f32 } else { 0.0 },
            invalid_share: if self.total > 0 { self.invalid as f32 / self.total as f32 } else { 1.0 },
            nearest_m: self.nearest.is_finite().then_some(self.nearest),
        }
    }
}
