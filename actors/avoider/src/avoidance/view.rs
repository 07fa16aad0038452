//! A depth grid checked and classified: which regions are blocked, which are unknown.

use kestrel_proto::messages::DepthGrid;

use crate::avoidance::error::GridError;

/// The centre region, `[row][column]`: the flight path (thesis §3.3.2 sizes it about five
/// times the vehicle).
const CENTRE: (usize, usize) = (1, 1);
/// The region below the centre: the ground ahead in level flight.
const BELOW_CENTRE: (usize, usize) = (2, 1);

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

    /// Whether the centre region (the flight path) is mostly invalid: open sky, or a
    /// textureless wall (see [`View::unknown_ahead`]).
    pub fn centre_unknown(&self) -> bool {
        self.unknown[CENTRE.0][CENTRE.1]
    }

    /// Whether the view ahead is unknown: the centre region *and* the one below it are mostly
    /// invalid. The centre alone cannot tell: in level flight its upper half is sky, which has
    /// no texture (measured in the simulator at 6 m: 75–90 % invalid with nothing ahead). A
    /// textureless wall ahead also hides the textured ground below the path, which open sky
    /// does not (the region below the centre is then ~30 % invalid).
    pub fn unknown_ahead(&self) -> bool {
        self.centre_unknown() && self.unknown[BELOW_CENTRE.0][BELOW_CENTRE.1]
    }

    /// The whole centre column (up, centre, down) is blocked: no way over or under in view.
    pub fn centre_column_blocked(&self, blocked_share: f64) -> bool {
        (0..3).all(|row| self.near[row][CENTRE.1] >= blocked_share)
    }

    /// The freer side to sidestep to: +1 right, −1 left. The side whose column has the smaller
    /// total near share (an unknown region counts as half blocked); on a tie the side whose
    /// middle region's nearest depth is farther (`nearest_m` as `[left, right]`, `None` = no
    /// valid pixel, taken as far); on a full tie right, as a fixed convention.
    pub fn freer_side(&self, nearest_m: [Option<f64>; 2]) -> f64 {
        let load = |col: usize| -> f64 {
            (0..3).map(|row| if self.unknown[row][col] { 0.5 } else { self.near[row][col] }).sum()
        };
        let (left, right) = (load(0), load(2));
        const TIE: f64 = 0.05;
        if (left - right).abs() > TIE {
            return if left < right { -1.0 } else { 1.0 };
        }
        let [l, r] = nearest_m.map(|d| d.unwrap_or(f64::INFINITY));
        if l > r { -1.0 } else { 1.0 }
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
