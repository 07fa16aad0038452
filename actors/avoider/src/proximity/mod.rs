//! Full-surround obstacle sectors for a flight controller's proximity library: each depth
//! grid's `OBSTACLE_DISTANCE` sectors (the camera's ~110° ahead) plus the obstacle memory's
//! points (what the camera saw and no longer sees, e.g. a trunk passed), rotated into the body
//! frame at the grid's capture instant, as one 72 × 5° `Proximity` message.
//!
//! Why: ArduPilot's simple avoidance and BendyRuler (and PX4's collision prevention) act on
//! what the proximity library holds. A forward camera alone tells them nothing of a trunk
//! beside the vehicle once it has left the view, where the avoider's own flights met every
//! collision (see [`crate::avoidance::memory`]).
//!
//! Conventions are MAVLink's and ArduPilot's `AP_Proximity_MAV` reading of them: body FRD,
//! sector `i` centred `angle_offset_deg + i · increment_deg` clockwise from forward, `u16::MAX`
//! where nothing is known, `max_distance_cm + 1` where the camera sees free space. ArduPilot
//! drops a reading below `min_distance_cm`, so a remembered point nearer than that is reported
//! at `min_distance_cm`: a trunk at 20 cm must not vanish
//! (`a_point_nearer_than_the_minimum_is_reported_at_the_minimum`).

pub mod actor;
pub mod params;

use kestrel_proto::Time;
use kestrel_proto::messages::{DepthGrid, NavState, OBSTACLE_SECTORS, Proximity, SECTOR_UNKNOWN};

use crate::avoidance::error::GridError;
use crate::avoidance::memory::{MemorySettings, ObstacleMemory, Pose};
use crate::avoidance::pose_history::PoseHistory;
use crate::avoidance::{CAPTURE_POSE_GAP_S, pose_gap_s};
use params::ProximityParams;

/// The sector layout must cover the full circle to this accuracy (deg): a remembered point is
/// placed by bearing, which needs every direction to have a sector.
const FULL_CIRCLE_TOLERANCE_DEG: f64 = 1e-3;

/// The full-surround sectors' pure core: poses in, depth grids in, `Proximity` out.
#[derive(Debug, Clone)]
pub struct SurroundSectors {
    settings: Option<MemorySettings>,
    max_grid_age_s: f64,
    memory: ObstacleMemory,
    poses: PoseHistory,
    /// Capture time of the last accepted grid.
    last: Option<Time>,
    /// Grids refused so far.
    rejected: u64,
}

impl SurroundSectors {
    /// A core with `params` (checked here).
    pub fn new(params: &ProximityParams) -> Result<SurroundSectors, crate::ParamsError> {
        params.validate()?;
        Ok(SurroundSectors {
            settings: params.memory_settings(),
            max_grid_age_s: params.max_grid_age_s,
            memory: ObstacleMemory::new(),
            poses: PoseHistory::default(),
            last: None,
            rejected: 0,
        })
    }

    /// Takes the pose (the estimator's, or the flight controller's in a companion graph). A
    /// state without a valid position or attitude empties the memory: it can no longer be placed.
    pub fn set_pose(&mut self, nav: &NavState) {
        match Pose::from_nav(nav) {
            Some(pose) => self.poses.push(pose),
            None => {
                self.poses.clear();
                self.memory.clear();
            }
        }
    }

    /// Points the memory holds.
    pub fn remembered(&self) -> usize {
        self.memory.len()
    }

    /// Grids refused so far.
    pub fn rejected(&self) -> u64 {
        self.rejected
    }

    /// The sectors all round at `grid`'s capture (arriving at `now`): its own readings, and each remembered point
    /// (after the grid has updated the memory) where it is nearer than the grid's reading or
    /// the grid has none. Without a pose within [`CAPTURE_POSE_GAP_S`] of the capture the
    /// memory is emptied (it cannot be placed) and the grid's readings go out alone.
    pub fn update(&mut self, now: Time, grid: &DepthGrid) -> Result<Proximity, GridError> {
        let checked = self.check(now, grid);
        if checked.is_err() {
            self.rejected += 1;
        }
        checked?;
        self.last = Some(grid.time);
        let mut sectors = grid.sectors.clone();
        let capture =
            self.poses.at(grid.time).filter(|p| pose_gap_s(p.time, grid.time) <= CAPTURE_POSE_GAP_S);
        let (Some(settings), Some(pose)) = (self.settings, capture) else {
            self.memory.clear();
            return Ok(Proximity {
                time: grid.time,
                frame_sequence: grid.frame_sequence,
                sectors,
                remembered_sectors: 0,
            });
        };
        self.memory.observe(&grid.sectors, &pose, &settings);
        let count = sectors.distances_cm.len() as i64;
        let increment_rad = f64::from(sectors.increment_deg).to_radians();
        let offset_rad = f64::from(sectors.angle_offset_deg).to_radians();
        let (min_cm, max_cm) = (sectors.min_distance_cm, sectors.max_distance_cm);
        let mut from_memory = [false; OBSTACLE_SECTORS];
        for (bearing_rad, range_m) in self.memory.around(&pose, &settings) {
            let index =
                (((bearing_rad - offset_rad) / increment_rad).round() as i64).rem_euclid(count) as usize;
            let cm = (range_m * 100.0).round().clamp(f64::from(min_cm), f64::from(max_cm)) as u16;
            let held = sectors.distances_cm[index];
            // Unknown and "free up to the maximum" are both above `max_cm`.
            if held > max_cm || cm < held {
                sectors.distances_cm[index] = cm;
                from_memory[index] = true;
            }
        }
        let remembered_sectors = from_memory.iter().filter(|&&m| m).count() as u8;
        Ok(Proximity { time: grid.time, frame_sequence: grid.frame_sequence, sectors, remembered_sectors })
    }

    /// Refuses a grid whose sectors are not 72 covering the full circle, that is not newer
    /// than the last accepted one, or that is older than `max_grid_age_s` at `now`.
    fn check(&self, now: Time, grid: &DepthGrid) -> Result<(), GridError> {
        let age_s = now.saturating_since(grid.time).as_secs_f64();
        if age_s > self.max_grid_age_s {
            return Err(GridError::TooOld { age_s, limit_s: self.max_grid_age_s });
        }
        let s = &grid.sectors;
        if s.distances_cm.len() != OBSTACLE_SECTORS {
            return Err(GridError::SectorCount { got: s.distances_cm.len(), expected: OBSTACLE_SECTORS });
        }
        let increment = f64::from(s.increment_deg);
        let full = increment * OBSTACLE_SECTORS as f64;
        if !(increment.is_finite() && (full - 360.0).abs() <= FULL_CIRCLE_TOLERANCE_DEG) {
            return Err(GridError::BadSectors { field: "increment_deg", value: s.increment_deg });
        }
        if !s.angle_offset_deg.is_finite() {
            return Err(GridError::BadSectors { field: "angle_offset_deg", value: s.angle_offset_deg });
        }
        if s.min_distance_cm >= s.max_distance_cm || s.max_distance_cm == SECTOR_UNKNOWN {
            return Err(GridError::SectorRange { min_cm: s.min_distance_cm, max_cm: s.max_distance_cm });
        }
        match self.last {
            Some(last) if grid.time <= last => Err(GridError::OutOfOrder { time: grid.time, last }),
            _ => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests;
