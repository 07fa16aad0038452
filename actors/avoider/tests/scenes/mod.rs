//! Depth grids and setpoints for the avoider's tests.

use kestrel_proto::Time;
use kestrel_proto::messages::{
    DepthGrid, GridRegion, OBSTACLE_SECTORS, ObstacleSectors, SECTOR_UNKNOWN, Setpoint, SetpointTarget,
    TrajectorySetpoint,
};

/// `seconds` on the graph clock.
pub fn at(seconds: f64) -> Time {
    Time::from_secs_f64(seconds)
}

/// A grid captured at `seconds` with these near shares and invalid shares, `[row][column]`.
pub fn grid(seconds: f64, near: [[f32; 3]; 3], invalid: [[f32; 3]; 3]) -> DepthGrid {
    let mut regions = [[GridRegion::default(); 3]; 3];
    for (row, cells) in regions.iter_mut().enumerate() {
        for (col, region) in cells.iter_mut().enumerate() {
            region.near_share = near[row][col];
            region.invalid_share = invalid[row][col];
            region.nearest_m = (invalid[row][col] < 1.0).then_some(nearest_m(near[row][col]));
        }
    }
    DepthGrid {
        time: at(seconds),
        frame_sequence: (seconds * 1000.0).round() as u64,
        threshold_m: 5.0,
        regions,
        sectors: ObstacleSectors {
            distances_cm: vec![SECTOR_UNKNOWN; OBSTACLE_SECTORS],
            increment_deg: 5.0,
            angle_offset_deg: 0.0,
            min_distance_cm: 30,
            max_distance_cm: 2000,
        },
    }
}

/// The nearest depth of a region with this near share (m): 2 m when mostly near (blocked),
/// 4.5 m when a few pixels are inside the 5 m threshold, 20 m (the far end of the stereo
/// range) when none is.
pub fn nearest_m(near_share: f32) -> f32 {
    if near_share >= 0.5 {
        2.0
    } else if near_share > 0.0 {
        4.5
    } else {
        20.0
    }
}

/// A grid with every pixel valid: only `near` matters.
pub fn clear_grid(seconds: f64, near: [[f32; 3]; 3]) -> DepthGrid {
    grid(seconds, near, [[0.0; 3]; 3])
}

/// Near shares with 1 at each listed `(row, column)` and 0 elsewhere.
pub fn blocked(cells: &[(usize, usize)]) -> [[f32; 3]; 3] {
    let mut near = [[0.0; 3]; 3];
    for &(row, col) in cells {
        near[row][col] = 1.0;
    }
    near
}

/// An armed trajectory setpoint flying north at `speed_m_s`.
pub fn flying_north(seconds: f64, speed_m_s: f64) -> Setpoint {
    Setpoint {
        time: at(seconds),
        armed: true,
        target: SetpointTarget::Trajectory(TrajectorySetpoint {
            velocity_ned_m_s: [Some(speed_m_s), Some(0.0), Some(0.0)],
            ..TrajectorySetpoint::default()
        }),
        landing: false,
        failed_motor: None,
    }
}
