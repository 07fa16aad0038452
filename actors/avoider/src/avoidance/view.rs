//! A depth grid checked and classified: which regions are blocked, which are unknown.

use kestrel_proto::messages::DepthGrid;

use crate::avoidance::error::GridError;

/// The centre region, `[row][column]`: the flight path (thesis §3.3.2 sizes it about five
/// times the vehicle).
const CENTRE: (usize, usize) = (1, 1);

/// The nine regions of one accepted depth grid, `[row][column]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    /// Share of valid pixels nearer than the grid's threshold, 0..1.
    pub near: [[f64; 3]; 3],
    /// Mostly invalid pixels: nothing can be said about the region.
    pub unknown: [[bool; 3]; 3],
}

impl View {
    /// Checks every share of `grid` and marks regions whose invalid share is above
    /// `unknown_invalid_share` as unknown.
    pub fn new(grid: &DepthGrid, unknown_invalid_share: f64) -> Result<View, GridError> {
        let mut view = View { near: [[0.0; 3]; 3], unknown: [[false; 3]; 3] };
        for (row, regions) in grid.regions.iter().enumerate() {
            for (col, region) in regions.iter().enumerate() {
                for (field, value) in
                    [("near_share", region.near_share), ("invalid_share", region.invalid_share)]
                {
                    if !(0.0..=1.0).contains(&value) {
                        return Err(GridError::BadShare { row, col, field, value });
                    }
                }
                view.near[row][col] = f64::from(region.near_share);
                view.unknown[row][col] = f64::from(region.invalid_share) > unknown_invalid_share;
            }
        }
        Ok(view)
    }

    /// The centre's near share.
    pub fn centre_near(&self) -> f64 {
        self.near[CENTRE.0][CENTRE.1]
    }

    /// Whether the centre region is unknown.
    pub fn centre_unknown(&self) -> bool {
        self.unknown[CENTRE.0][CENTRE.1]
    }

    /// No way through: the centre is blocked by near pixels and every other region is blocked
    /// or unknown (an unknown region is no way out either). A view that is unknown in the
    /// centre does not count: it may be open sky, and the unknown-centre slow-down covers it.
    pub fn all_blocked(&self, blocked_share: f64) -> bool {
        self.near
            .iter()
            .flatten()
            .zip(self.unknown.iter().flatten())
            .all(|(&near, &unknown)| near >= blocked_share || unknown)
            && self.centre_near() >= blocked_share
    }
}
