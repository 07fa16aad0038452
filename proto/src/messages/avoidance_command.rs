//! What the obstacle avoider asks of the commander: a body-frame velocity correction computed
//! from one [`DepthGrid`](super::DepthGrid) and the desired speed (thesis §3.3.8), with what
//! went into it and how far it can be trusted.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// Rules in the thesis's avoider rule base (table 3.1); the avoider refuses other rule counts
/// so that every rule's activation has a fixed place in the log.
pub const AVOIDER_RULES: usize = 18;

/// The fuzzy engine's crisp outputs in the thesis's avoider axes (§3.3.4, table 3.1):
/// dimensionless, −1..1, where ±1 stands for the configured maximum speed.
///
/// The thesis's axes are x right, y forward, z up. Table 3.1 fixes the signs: an obstacle up
/// and left (`D_lu`) gives Vx SP (move right, away from it) and Vz SN (move down, away from
/// it); an obstacle down (`D_cd`) gives Vz SP (up); a blocked centre gives Vy negative (brake).
/// [`FuzzyVelocity::to_frd`] is the one place these axes become body FRD.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct FuzzyVelocity {
    /// Thesis `V_x`: lateral, positive to the right.
    pub vx_right: f64,
    /// Thesis `V_y`: forward, positive forward (the rule base only brakes: ≤ 0).
    pub vy_forward: f64,
    /// Thesis `V_z`: vertical, positive up.
    pub vz_up: f64,
}

impl FuzzyVelocity {
    /// The same vector in body FRD `[forward, right, down]`, still dimensionless:
    /// forward = `vy_forward`, right = `vx_right`, down = −`vz_up`.
    pub fn to_frd(self) -> [f64; 3] {
        [self.vy_forward, self.vx_right, -self.vz_up]
    }
}

/// How far an [`AvoidanceCommand`] can be trusted, and which of the avoider's own behaviours
/// beyond the thesis's rule base shaped it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct AvoidanceHealth {
    /// Age of the newest accepted depth grid when the command was made (s); `None` before the
    /// first grid.
    pub grid_age_s: Option<f64>,
    /// No depth grid within the avoider's age limit: the view is unknown, the grid is ignored,
    /// the correction brakes forward motion and lets lateral and vertical corrections decay.
    pub stale: bool,
    /// Regions whose pixels were mostly invalid (no disparity), `[row][column]` as in
    /// [`DepthGrid::regions`](super::DepthGrid::regions). All false when `stale`.
    pub unknown_regions: [[bool; 3]; 3],
    /// The view ahead (the centre region and the one below it) was unknown, so the avoider
    /// slowed or stopped the vehicle (the textureless wall of thesis §4.2.3).
    pub unknown_centre_slowdown: bool,
    /// The centre region (the flight path) was blocked, by near pixels or by a depth within
    /// the sidestep distance, so the avoider stopped forward progress whatever the rule base
    /// said.
    pub centre_blocked: bool,
    /// Lateral speed of the sidestep under way (m/s, + right, 0 = none): the path was blocked
    /// and the rule base gave no way around.
    pub sidestep_m_s: f64,
    /// Forward speed the vehicle was held below so that it can stop short of the nearest depth
    /// ahead (m/s); `None` when the centre had no valid depth.
    pub forward_cap_m_s: Option<f64>,
    /// Every region was blocked: the avoider climbs until the centre clears (thesis §6).
    pub climbing: bool,
    /// The short-term obstacle memory limited the horizontal velocity: something seen earlier,
    /// possibly out of view now, was too close in the direction of motion.
    pub memory_limited: bool,
    /// Depth grids refused since start (non-finite or out-of-range shares, out of order, older
    /// than the limit on arrival).
    pub grids_rejected: u64,
    /// Setpoints refused since start (non-finite velocity).
    pub setpoints_rejected: u64,
}

/// What the distance ahead that the camera vouches for was taken from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum ClearRangeReason {
    /// No fresh depth grid (or none yet): the camera vouches for nothing, the range is 0.
    #[default]
    Stale,
    /// The nearest depth in the centre region (the flight path).
    Obstacle,
    /// The nearest return of the `OBSTACLE_DISTANCE` sectors that can lie in the vehicle's
    /// corridor (the avoider's `path_half_width_m`): a thin object, too few pixels for the
    /// centre region's nearest depth.
    ObstacleInPath,
    /// The centre region is mostly invalid but the ground below it is seen: open sky, or a
    /// textureless wall not yet called unknown. The range is the avoider's conservative
    /// `unknown_range_m`, the distance at which such a wall is reliably called unknown.
    Untextured,
    /// The view ahead is unknown (the centre and the region below it mostly invalid, thesis
    /// §4.2.3): the range is 0.
    UnknownAhead,
    /// The centre and the region below it are mostly invalid, but the vehicle is higher than
    /// the avoider's `ground_match_height_m`, where the ground below the path is too far for
    /// a disparity: open sky and far ground look so, and the view says nothing either way. The
    /// range is `unknown_range_m`, as for [`ClearRangeReason::Untextured`].
    GroundOutOfReach,
    /// Nothing in the centre within the stereo range: the farthest depth the grid reports
    /// (`DepthGrid::sectors.max_distance_cm`, the stereo pair's reliable range).
    StereoRange,
}

impl ClearRangeReason {
    /// Short name for a status text or log.
    pub fn as_str(self) -> &'static str {
        match self {
            ClearRangeReason::Stale => "stale",
            ClearRangeReason::Obstacle => "obstacle",
            ClearRangeReason::ObstacleInPath => "obstacle in path",
            ClearRangeReason::Untextured => "untextured",
            ClearRangeReason::UnknownAhead => "unknown ahead",
            ClearRangeReason::GroundOutOfReach => "ground out of reach",
            ClearRangeReason::StereoRange => "stereo range",
        }
    }
}

/// The distance straight ahead (along the body's forward axis, from the camera) that the
/// view vouches for at the grid's capture time, and why: the commander caps the forward speed
/// so that the vehicle can stop inside it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ClearRange {
    /// Distance (m), finite and ≥ 0.
    pub range_m: f64,
    pub reason: ClearRangeReason,
}

/// The avoider's velocity correction, published for every accepted depth grid and, while the
/// grids are stale, on the avoider's staleness timer.
///
/// The commander adds `velocity_frd_m_s` to its own desired velocity (after rotating it into
/// NED with the vehicle's attitude), as the thesis fed the avoider's body-frame velocities to
/// the position controller (§3.3.8).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct AvoidanceCommand {
    /// Capture time of the depth grid the command was computed from; the avoider's clock time
    /// for a command made on its staleness timer.
    pub time: Time,
    /// Capture time of the newest accepted depth grid; `None` before the first.
    pub grid_time: Option<Time>,
    /// Frame sequence number of that grid; `None` before the first.
    pub frame_sequence: Option<u64>,
    /// Velocity correction, body frame FRD `[forward, right, down]` (m/s), low-pass filtered.
    pub velocity_frd_m_s: [f64; 3],
    /// The rule base's raw (unfiltered) outputs in the thesis's axes; zero when `stale`.
    pub fuzzy: FuzzyVelocity,
    /// Activation degree of each rule of table 3.1, in the rule base's order, 0..1; zero when
    /// `stale`.
    pub rule_activations: [f32; AVOIDER_RULES],
    /// The near-pixel shares fed to the rule base, `[row][column]` as in
    /// [`DepthGrid::regions`](super::DepthGrid::regions) (`[0][0]` is `D_lu`, `[1][1]` `D_cc`,
    /// `[2][2]` `D_rd`); zero when `stale`.
    pub near_shares: [[f32; 3]; 3],
    /// Desired horizontal speed the command assumed (m/s).
    pub desired_speed_m_s: f64,
    /// The rule base's `V_in`: desired speed over the configured maximum, 0..1.
    pub speed_input: f64,
    pub health: AvoidanceHealth,
    /// What the view vouches for ahead; range 0 (`Stale`) in older logs.
    #[serde(default)]
    pub clear_range: ClearRange,
}
crate::impl_message!(AvoidanceCommand);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thesis_axes_map_to_frd() {
        let v = FuzzyVelocity { vx_right: 0.25, vy_forward: -0.5, vz_up: 0.75 };
        assert_eq!(v.to_frd(), [-0.5, 0.25, -0.75]);
    }
}
