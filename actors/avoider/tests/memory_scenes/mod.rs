//! Sectors and poses for the tests of the avoider's obstacle memory.

use kestrel_proto::messages::{DepthGrid, NavState};

use crate::scenes::at;

/// `grid` with the `OBSTACLE_DISTANCE` sectors of a 110° camera (sectors −11..=11, negative
/// anticlockwise from forward): free up to 20 m in view but for the `(sector, range m)` listed.
pub fn with_sectors(mut grid: DepthGrid, readings: &[(i32, f64)]) -> DepthGrid {
    let distances = &mut grid.sectors.distances_cm;
    for s in -11i32..=11 {
        distances[s.rem_euclid(72) as usize] = 2001;
    }
    for &(s, range) in readings {
        distances[s.rem_euclid(72) as usize] = (range * 100.0).round() as u16;
    }
    grid
}

/// The estimator's state at `seconds`: level, heading north, at `north_m`, `east_m`, 5 m up.
pub fn nav_at(seconds: f64, north_m: f64, east_m: f64) -> NavState {
    NavState::exact(at(seconds), [1.0, 0.0, 0.0, 0.0], [0.0; 3], [0.0; 3], [north_m, east_m, -5.0])
}
