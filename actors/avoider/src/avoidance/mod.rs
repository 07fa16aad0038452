//! The avoider's pure core: depth grid and desired speed in, body-frame velocity correction out
//! (thesis §3.3), with what the thesis lacked around the rule base.
//!
//! For every accepted depth grid [`Avoider::update`]:
//! 1. checks the grid (shares in 0..1, newer than the last, not older than the age limit on
//!    arrival) and marks mostly-invalid regions unknown ([`View`]);
//! 2. feeds the nine near shares and `V_in` = desired speed / maximum speed to the rule base
//!    (the mapping lives in [`region_inputs`]) and scales its outputs by the maximum speed;
//! 3. applies the avoider's own behaviours, each reported in the command's health:
//!    * centre blocked (near share ≥ `blocked_share`): forward progress stops whatever the rule
//!      base says — table 3.1 only answers when exactly one off-centre region is blocked too, so
//!      a pole straight ahead with a clear view around it would otherwise get no correction;
//!    * path blocked and no way over or under given by the rule base: a sidestep at
//!      `sidestep_speed_m_s` (or the rule base's lateral way, if faster) towards the rule
//!      base's side or, without one, the freer side ([`View::freer_side`]), latched until the
//!      path clears (below `climb_exit_share`) so that the vehicle does not dither between
//!      sides; the path also counts as blocked when the centre's nearest depth is within
//!      `sidestep_distance_m` (a thin trunk fills little of the region);
//!    * boxed in: a sidestep that has turned back to a side it gave up (each side closed in
//!      turn, by what is in view or remembered) climbs as if every region were blocked, until
//!      the path clears — sliding on between the two would dither in front of the obstacle
//!      until the memory forgot one side (decision 0039); so does a
//!      sidestep that has slid `sidestep_max_m` from where it began: the camera does not see
//!      sideways, and a long slide runs into what nearer trunks hid while it was in view
//!      (a slide of a few metres reaches such a trunk);
//!    * view ahead unknown (the textureless wall of §4.2.3, [`View::unknown_ahead`]): the
//!      vehicle keeps at most `unknown_speed_share` of its desired speed (0 by default: stop);
//!      not above `ground_match_height_m` over the ground ([`ground_height`]: the downward
//!      rangefinder, else home), where the ground below the path is out of the stereo pair's
//!      reach and an invalid view is what open sky and far ground look like;
//!    * every region blocked: forward progress stops and the vehicle climbs at
//!      `climb_speed_m_s` until the centre's near share falls below `climb_exit_share` (§6),
//!      and `climb_margin_m` more;
//! 4. low-pass filters the result (§3.3.9);
//! 5. caps the forward speed so that the vehicle can stop `stop_distance_m` short of the
//!    centre's nearest depth, braking at `brake_decel_m_s2` after `reaction_time_s` (PX4's
//!    collision prevention does the same with its `CP_DIST`). The cap comes after the filter:
//!    a safety limit must not lag behind the view;
//! 6. limits the horizontal velocity towards every obstacle in the short-term
//!    [`ObstacleMemory`] (what the camera saw, placed in NED with the estimator's pose, so it
//!    still counts once out of view) so that the vehicle can stop `memory_stop_distance_m`
//!    short of it. The memory also closes a side to the sidestep. Without poses (the actor's
//!    `nav` port unrouted) or with `memory_time_s = 0` there is no memory.
//!
//! [`Avoider::check`] runs on a timer: once the newest grid is older than `max_grid_age_s` the
//! view is unknown, so the grid is ignored and the correction, through the same filter, brakes
//! forward motion to a stop and lets lateral and vertical corrections (and any climb) decay to
//! zero. Holding the last correction would steer on a view that no longer exists; releasing it
//! would fly on blind, which is how the thesis's vehicle met the wall. The commander sees
//! `stale` and decides on its failsafe.
//!
//! No step allocates: the rule base's workspace is made once and the command is plain arrays.

mod desired_speed;
pub mod error;
pub mod ground_height;
pub mod live_params;
mod low_pass;
pub mod memory;
pub mod params;
pub mod path;
pub(crate) mod pose_history;
pub mod region_inputs;
mod view;

use kestrel_proto::Time;
use kestrel_proto::messages::{
    AVOIDER_RULES, AvoidanceCommand, AvoidanceHealth, ClearRange, ClearRangeReason, DepthGrid, FuzzyVelocity,
    NavState, RangefinderSample, Setpoint,
};
use kestrel_proto::speed_cap::Braking;

use crate::engine::{Engine, Workspace};

/// A lateral or vertical correction of the rule base at least this large (m/s) is a way around
/// the obstacle: a lateral one picks the sidestep's side, a vertical one (over or under) is
/// flown without a sidestep.
const WAY_M_S: f64 = 0.3;
/// A sidestep that turns this many times has come back to a side it gave up: boxed in.
const BOXED_IN_TURNS: u32 = 2;
/// A grid is placed in the world (the obstacle memory) only with a pose at most this far from
/// its capture time (s): five of the pose history's 20 ms slots, 0.5 m at 5 m/s. Poses further
/// off mean the estimator's state stopped coming, which the flight side flies through blind for
/// up to `failsafe.nav_stale_s` (1 s, 5 m at 5 m/s).
pub(crate) const CAPTURE_POSE_GAP_S: f64 = 0.1;

/// Seconds between two times, either way round.
pub(crate) fn pose_gap_s(a: Time, b: Time) -> f64 {
    a.saturating_since(b).max(b.saturating_since(a)).as_secs_f64()
}
pub use desired_speed::desired_speed_m_s;
use error::{AvoiderError, GridError, ParamsError, SetpointError};
use ground_height::{GroundHeight, HeightSource};
pub use low_pass::LowPass;
pub use memory::{MemorySettings, ObstacleMemory, Pose};
use params::AvoiderParams;
use pose_history::PoseHistory;
use region_inputs::InputMap;
pub use view::View;

/// Test sectors as the stereo actor lays them out (72 of 5° from straight ahead, 0.3–20 m),
/// unknown but for `set` (sector index, cm).
#[cfg(test)]
pub(crate) fn test_sectors(
    set: impl IntoIterator<Item = (usize, u16)>,
) -> kestrel_proto::messages::ObstacleSectors {
    use kestrel_proto::messages::{OBSTACLE_SECTORS, ObstacleSectors, SECTOR_UNKNOWN};
    let mut distances_cm = vec![SECTOR_UNKNOWN; OBSTACLE_SECTORS];
    for (index, cm) in set {
        distances_cm[index] = cm;
    }
    ObstacleSectors {
        distances_cm,
        increment_deg: 5.0,
        angle_offset_deg: 0.0,
        min_distance_cm: 30,
        max_distance_cm: 2000,
    }
}

/// The sidestep under way, kept until the path clears.
#[derive(Debug, Clone, Copy, Default)]
struct Sidestep {
    /// Its side (+1 right, −1 left); `None` while there is none.
    side: Option<f64>,
    /// Times it turned to the other side.
    turns: u32,
    /// Where it began (north, east; m), when the estimator's pose was known.
    start_ne_m: Option<[f64; 2]>,
}

impl Sidestep {
    /// No sidestep under way any more: the next one chooses its side afresh.
    fn end(&mut self) {
        *self = Sidestep::default();
    }
}

/// The obstacle avoider's state between depth grids.
#[derive(Debug, Clone)]
pub struct Avoider {
    engine: Engine,
    workspace: Workspace,
    map: InputMap,
    params: AvoiderParams,
    filter: LowPass,
    /// Desired horizontal speed from the newest accepted setpoint (m/s); 0 before the first.
    desired_speed_m_s: f64,
    /// Capture time and frame sequence of the newest accepted grid.
    last_grid: Option<(Time, u64)>,
    /// Every region was blocked and the centre has not cleared yet.
    climb_latched: bool,
    /// The climb goes on until then: the centre cleared, `climb_margin_m` more.
    climb_margin_until: Option<Time>,
    sidestep: Sidestep,
    /// Boxed in: climbing until the path clears (see the module docs).
    boxed_in: bool,
    /// What the camera saw, in NED (empty without poses).
    memory: ObstacleMemory,
    /// The estimator's recent poses; empty while none has arrived or the position is invalid.
    poses: PoseHistory,
    /// Home and the downward rangefinder, for the height above the ground.
    ground: GroundHeight,
    grids_rejected: u64,
    setpoints_rejected: u64,
}

impl Avoider {
    /// An avoider running `engine`, which must have the thesis rule base's interface (inputs
    /// `D_lu … D_rd`, `V_in`; outputs `Vx`, `Vy`, `Vz`; [`AVOIDER_RULES`] rules).
    pub fn new(engine: Engine, params: AvoiderParams) -> Result<Avoider, AvoiderError> {
        params.validate()?;
        let map = InputMap::new(&engine)?;
        let rules: usize = engine.blocks().iter().map(|b| b.rules.len()).sum();
        if rules != AVOIDER_RULES {
            return Err(AvoiderError::RuleCount {
                rule_base: engine.name().to_string(),
                expected: AVOIDER_RULES,
                got: rules,
            });
        }
        Ok(Avoider {
            workspace: engine.workspace(),
            engine,
            map,
            filter: LowPass::new(params.filter_time_constant_s),
            params,
            desired_speed_m_s: 0.0,
            last_grid: None,
            climb_latched: false,
            climb_margin_until: None,
            sidestep: Sidestep::default(),
            boxed_in: false,
            memory: ObstacleMemory::new(),
            poses: PoseHistory::default(),
            ground: GroundHeight::default(),
            grids_rejected: 0,
            setpoints_rejected: 0,
        })
    }

    /// An avoider running the built-in thesis rule base.
    pub fn thesis(params: AvoiderParams) -> Result<Avoider, AvoiderError> {
        Avoider::new(crate::thesis_engine()?, params)
    }

    /// The parameters it runs with.
    pub fn params(&self) -> &AvoiderParams {
        &self.params
    }

    /// Runs with `params` from the next grid on (the rule base and the filter's output are
    /// kept); refused, with nothing changed, when they do not validate.
    pub fn retune(&mut self, params: AvoiderParams) -> Result<(), ParamsError> {
        params.validate()?;
        self.filter.set_time_constant(params.filter_time_constant_s);
        self.params = params;
        Ok(())
    }

    /// Depth grids refused since start.
    pub fn grids_rejected(&self) -> u64 {
        self.grids_rejected
    }

    /// Setpoints refused since start.
    pub fn setpoints_rejected(&self) -> u64 {
        self.setpoints_rejected
    }

    /// Takes the desired speed from the commander's newest setpoint. A refused setpoint is
    /// counted and the previous speed stays.
    pub fn set_setpoint(&mut self, setpoint: &Setpoint) -> Result<(), SetpointError> {
        match desired_speed_m_s(setpoint) {
            Ok(speed) => {
                self.desired_speed_m_s = speed;
                Ok(())
            }
            Err(e) => {
                self.setpoints_rejected += 1;
                Err(e)
            }
        }
    }

    /// Takes the estimator's pose for the obstacle memory. A state without a valid horizontal
    /// position or attitude empties the memory: what it holds can no longer be placed.
    pub fn set_pose(&mut self, nav: &NavState) {
        let Some(pose) = Pose::from_nav(nav) else {
            self.poses.clear();
            self.memory.clear();
            self.sidestep.start_ne_m = None;
            return;
        };
        self.ground.set_attitude(nav.attitude);
        self.poses.push(pose);
    }

    /// Home's NED position in the estimator's frame, from the commander's status (`None`: no
    /// home yet), for the height above the ground ([`ground_height`]).
    pub fn set_home(&mut self, home_ned_m: Option<[f64; 3]>) {
        self.ground.set_home(home_ned_m);
    }

    /// A rangefinder sample; the downward one measures the height above the ground.
    pub fn set_range(&mut self, sample: &RangefinderSample) {
        self.ground.set_range(sample);
    }

    /// The height above the ground at `now` (m) and its source, if a pose has arrived.
    pub fn height_above_ground_m(&self, now: Time) -> Option<(f64, HeightSource)> {
        self.poses.newest().map(|pose| self.ground.above_ground_m(now, pose.ned_m[2]))
    }

    /// Obstacle points remembered now.
    pub fn remembered(&self) -> usize {
        self.memory.len()
    }

    /// Computes the correction for `grid`, arriving at `now` on the graph clock. A refused grid
    /// is counted and changes nothing else.
    pub fn update(&mut self, now: Time, grid: &DepthGrid) -> Result<AvoidanceCommand, GridError> {
        let result = self.accept(now, grid);
        if result.is_err() {
            self.grids_rejected += 1;
        }
        result
    }

    /// The staleness check: `None` while the newest grid is within the age limit; otherwise
    /// the stale command (see the module docs), advanced to `now`.
    pub fn check(&mut self, now: Time) -> Option<AvoidanceCommand> {
        let grid_age_s = self.last_grid.map(|(time, _)| now.saturating_since(time).as_secs_f64());
        if grid_age_s.is_some_and(|age| age <= self.params.max_grid_age_s) {
            return None;
        }
        self.climb_latched = false;
        self.climb_margin_until = None;
        self.boxed_in = false;
        self.sidestep.end();
        let brake = [-self.desired_speed_m_s, 0.0, 0.0];
        let braking = self.filter.update(now, brake);
        let (velocity_frd_m_s, memory_limited) = self.limit_by_memory(braking);
        Some(AvoidanceCommand {
            time: now,
            grid_time: self.last_grid.map(|(time, _)| time),
            frame_sequence: self.last_grid.map(|(_, sequence)| sequence),
            velocity_frd_m_s,
            fuzzy: FuzzyVelocity::default(),
            rule_activations: [0.0; AVOIDER_RULES],
            near_shares: [[0.0; 3]; 3],
            desired_speed_m_s: self.desired_speed_m_s,
            speed_input: self.speed_input(),
            health: AvoidanceHealth { grid_age_s, stale: true, memory_limited, ..self.counters() },
            clear_range: ClearRange::default(),
        })
    }

    fn accept(&mut self, now: Time, grid: &DepthGrid) -> Result<AvoidanceCommand, GridError> {
        if let Some((last, _)) = self.last_grid
            && grid.time <= last
        {
            return Err(GridError::OutOfOrder { time: grid.time, last });
        }
        let age_s = now.saturating_since(grid.time).as_secs_f64();
        if age_s > self.params.max_grid_age_s {
            return Err(GridError::TooOld { age_s, limit_s: self.params.max_grid_age_s });
        }
        let sectors = &grid.sectors;
        if !(sectors.increment_deg.is_finite() && sectors.increment_deg > 0.0) {
            return Err(GridError::BadSectors { field: "increment_deg", value: sectors.increment_deg });
        }
        if !sectors.angle_offset_deg.is_finite() {
            return Err(GridError::BadSectors { field: "angle_offset_deg", value: sectors.angle_offset_deg });
        }
        let view = View::new(grid, self.params.unknown_invalid_share)?;
        let speed_input = self.speed_input();
        let inputs = self.map.inputs(&view.near, speed_input);
        let outputs = self.engine.infer(&mut self.workspace, &inputs)?;
        // A rule base whose rules all miss gives NaN: no rule, no correction.
        let [vx_right, vy_forward, vz_up] =
            self.map.outputs(outputs).map(|v| if v.is_nan() { 0.0 } else { v });
        let fuzzy = FuzzyVelocity { vx_right, vy_forward, vz_up };
        let mut rule_activations = [0.0; AVOIDER_RULES];
        for (slot, &degree) in rule_activations.iter_mut().zip(self.workspace.rule_degrees()) {
            *slot = degree as f32;
        }
        self.last_grid = Some((grid.time, grid.frame_sequence));
        // High up, the ground below the path is out of the stereo pair's reach: an invalid
        // view ahead is then no sign of a wall (see `ground_match_height_m`), and vouches for
        // `unknown_range_m` in the memory as for the speed cap.
        let ground_out_of_reach = self
            .height_above_ground_m(now)
            .is_some_and(|(height_m, _)| height_m > self.params.ground_match_height_m);
        let unmeasured_clear_m = if ground_out_of_reach { self.params.unknown_range_m } else { 0.0 };
        let settings = self.memory_settings().map(|s| MemorySettings { unmeasured_clear_m, ..s });
        match (settings, self.poses.at(grid.time)) {
            (Some(settings), Some(capture)) if pose_gap_s(capture.time, grid.time) <= CAPTURE_POSE_GAP_S => {
                self.memory.observe(&grid.sectors, &capture, &settings)
            }
            // The estimator's poses stopped around the capture: the grid cannot be placed, and
            // what the memory holds stays.
            (Some(_), Some(_)) => {}
            _ => self.memory.clear(),
        }

        let p = &self.params;
        let region_nearest = |row: usize, col: usize| {
            grid.regions[row][col].nearest_m.map(f64::from).filter(|d| d.is_finite())
        };
        let nearest_ahead = region_nearest(1, 1);
        let near_ahead = nearest_ahead.is_some_and(|d| d < p.sidestep_distance_m);
        let latched = if self.climb_latched {
            view.centre_near() >= p.climb_exit_share
        } else {
            view.all_blocked(p.blocked_share)
        };
        let boxed_in = self.boxed_in && (view.centre_near() >= p.climb_exit_share || near_ahead);
        if (self.climb_latched && !latched) || (self.boxed_in && !boxed_in) {
            // The centre band clears with the obstacle's top still a few decimetres below the
            // camera, and the airframe reaches below it: without the margin it clips the top.
            let margin_us = (p.climb_margin_m / p.climb_speed_m_s * 1e6).round() as u64;
            self.climb_margin_until = Some(Time(grid.time.0.saturating_add(margin_us)));
        }
        self.climb_latched = latched;
        self.boxed_in = boxed_in;
        let climbing = latched || boxed_in || self.climb_margin_until.is_some_and(|until| grid.time < until);
        // Once a side is taken the path stays blocked down to the climb's exit share: a trunk
        // filling about half the centre must not flip it between blocked and clear, re-choosing
        // a side each time (the vehicle dithered in front of two trunks for 100 s).
        let blocked_share = if self.sidestep.side.is_some() { p.climb_exit_share } else { p.blocked_share };
        let centre_blocked = view.centre_near() >= blocked_share || near_ahead;
        let unknown_ahead = view.unknown_ahead() && !ground_out_of_reach;
        let desired = self.desired_speed_m_s;
        let target = if climbing {
            self.sidestep.end();
            [-desired, 0.0, -p.climb_speed_m_s]
        } else {
            let mut target = fuzzy.to_frd().map(|v| v * p.max_speed_m_s);
            if centre_blocked {
                target[0] = target[0].min(-desired);
                let column_blocked = view.centre_column_blocked(p.blocked_share);
                let lateral_way = target[1].abs() >= WAY_M_S;
                let vertical_way = target[2].abs() >= WAY_M_S && !column_blocked;
                let sidestepping = self.sidestep.side.is_some() || !vertical_way || lateral_way;
                if p.sidestep_speed_m_s > 0.0 && sidestepping {
                    // A side is kept until the path clears: the rule base's own way if it
                    // gives one, else the freer side.
                    let sides_nearest = [region_nearest(1, 0), region_nearest(1, 2)];
                    // Measured from the first pose of the sidestep, if it began without one.
                    if self.sidestep.start_ne_m.is_none() {
                        self.sidestep.start_ne_m =
                            self.poses.newest().map(|pose| [pose.ned_m[0], pose.ned_m[1]]);
                    }
                    let mut side = *self.sidestep.side.get_or_insert_with(|| {
                        if lateral_way { target[1].signum() } else { view.freer_side(sides_nearest) }
                    });
                    let slid_m = self
                        .sidestep
                        .start_ne_m
                        .zip(self.poses.newest())
                        .map(|(start, pose)| (pose.ned_m[0] - start[0]).hypot(pose.ned_m[1] - start[1]));
                    if slid_m.is_some_and(|slid| slid >= p.sidestep_max_m) {
                        self.boxed_in = true;
                    }
                    // Never slide into something close on the side under way, in view or
                    // remembered: turn to the other side if that one is not close too.
                    let close = |d: Option<f64>| d.is_some_and(|d| d < p.sidestep_distance_m);
                    let [left, right] = [(sides_nearest[0], -1.0), (sides_nearest[1], 1.0)]
                        .map(|(nearest, side)| close(nearest) || self.side_closed_by_memory(side));
                    let (ahead, other) = if side > 0.0 { (right, left) } else { (left, right) };
                    if ahead && !other {
                        side = -side;
                        self.sidestep.side = Some(side);
                        self.sidestep.turns += 1;
                        self.boxed_in |= self.sidestep.turns >= BOXED_IN_TURNS;
                    }
                    // The rule base's lateral answer stands when it goes the same way faster.
                    if target[1] * side < p.sidestep_speed_m_s {
                        target[1] = side * p.sidestep_speed_m_s;
                    }
                    if column_blocked {
                        target[2] = 0.0;
                    }
                }
            } else {
                self.sidestep.end();
            }
            if unknown_ahead {
                target[0] = target[0].min(-(1.0 - p.unknown_speed_share) * desired);
            }
            target
        };
        let mut velocity_frd_m_s = self.filter.update(now, target);
        let forward_cap_m_s = nearest_ahead.map(|d| self.forward_speed_cap_m_s(d));
        if let Some(cap) = forward_cap_m_s {
            velocity_frd_m_s[0] = velocity_frd_m_s[0].min(cap - desired);
        }
        let (velocity_frd_m_s, memory_limited) = self.limit_by_memory(velocity_frd_m_s);
        Ok(AvoidanceCommand {
            time: grid.time,
            grid_time: Some(grid.time),
            frame_sequence: Some(grid.frame_sequence),
            velocity_frd_m_s,
            fuzzy,
            rule_activations,
            near_shares: grid.regions.map(|row| row.map(|region| region.near_share)),
            desired_speed_m_s: desired,
            speed_input,
            health: AvoidanceHealth {
                grid_age_s: Some(age_s),
                unknown_regions: view.unknown,
                unknown_centre_slowdown: unknown_ahead,
                centre_blocked,
                sidestep_m_s: self.sidestep.side.map_or(0.0, |side| side * p.sidestep_speed_m_s),
                forward_cap_m_s,
                climbing,
                memory_limited,
                ..self.counters()
            },
            clear_range: self.clear_range(&view, ground_out_of_reach, nearest_ahead, grid),
        })
    }

    /// The distance ahead `view` vouches for (see [`ClearRangeReason`]): an unknown view ahead
    /// vouches for nothing, unless the ground below the path is out of the stereo pair's reach;
    /// otherwise the nearest of the centre's nearest depth and the sectors' nearest return in
    /// the vehicle's corridor ([`path`]), no farther than the conservative `unknown_range_m`
    /// while the centre is mostly invalid, nor than the grid's reliable stereo range.
    fn clear_range(
        &self,
        view: &View,
        ground_out_of_reach: bool,
        nearest_ahead: Option<f64>,
        grid: &DepthGrid,
    ) -> ClearRange {
        let unknown_reason = match (view.unknown_ahead(), ground_out_of_reach) {
            (true, false) => return ClearRange { range_m: 0.0, reason: ClearRangeReason::UnknownAhead },
            (true, true) => ClearRangeReason::GroundOutOfReach,
            (false, _) => ClearRangeReason::Untextured,
        };
        let stereo = ClearRange {
            range_m: f64::from(grid.sectors.max_distance_cm) / 100.0,
            reason: ClearRangeReason::StereoRange,
        };
        let untextured = view
            .centre_unknown()
            .then_some(ClearRange { range_m: self.params.unknown_range_m, reason: unknown_reason });
        let obstacle = nearest_ahead
            .filter(|d| *d >= 0.0)
            .map(|range_m| ClearRange { range_m, reason: ClearRangeReason::Obstacle });
        let in_path = path::nearest_in_path_m(&grid.sectors, self.params.path_half_width_m)
            .map(|range_m| ClearRange { range_m, reason: ClearRangeReason::ObstacleInPath });
        [untextured, obstacle, in_path]
            .into_iter()
            .flatten()
            .fold(stereo, |nearest, r| if r.range_m < nearest.range_m { r } else { nearest })
    }

    /// The memory's settings, `None` when it is off.
    fn memory_settings(&self) -> Option<MemorySettings> {
        let p = &self.params;
        (p.memory_time_s > 0.0).then_some(MemorySettings {
            time_s: p.memory_time_s,
            range_m: p.memory_range_m,
            height_m: p.memory_height_m,
            keep_within_m: p.sidestep_distance_m,
            unmeasured_clear_m: 0.0,
        })
    }

    /// The speed (m/s) from which the vehicle can still stop `memory_stop_distance_m` short of
    /// a remembered point `range_m` away.
    fn memory_speed_cap_m_s(&self, range_m: f64) -> f64 {
        self.stopping_speed_m_s(range_m - self.params.memory_stop_distance_m)
    }

    /// Whether the memory holds a point beside the vehicle on `side` (+1 right, −1 left;
    /// within 45° of abeam) so near that a sidestep there could not keep its speed.
    fn side_closed_by_memory(&self, side: f64) -> bool {
        let (Some(settings), Some(pose)) = (self.memory_settings(), self.poses.newest()) else {
            return false;
        };
        let abeam = side * std::f64::consts::FRAC_PI_2;
        self.memory
            .nearest_towards(&pose, &settings, abeam, std::f64::consts::FRAC_PI_4)
            .is_some_and(|range| self.memory_speed_cap_m_s(range) < self.params.sidestep_speed_m_s)
    }

    /// `velocity_frd_m_s` (the correction) with the vehicle's horizontal velocity (the desired
    /// speed forward plus the correction) limited towards every remembered point; whether a
    /// point limited it.
    fn limit_by_memory(&self, velocity_frd_m_s: [f64; 3]) -> ([f64; 3], bool) {
        let (Some(settings), Some(pose)) = (self.memory_settings(), self.poses.newest()) else {
            return (velocity_frd_m_s, false);
        };
        let desired = self.desired_speed_m_s;
        let [forward, right, down] = velocity_frd_m_s;
        let ([forward, right], limited) =
            self.memory.limit(&pose, &settings, [desired + forward, right], |range| {
                self.memory_speed_cap_m_s(range)
            });
        ([forward - desired, right, down], limited)
    }

    /// The forward speed (m/s) from which the vehicle can still stop `stop_distance_m` short of
    /// a depth `distance_m` ahead: it covers `v·t_r` before braking and `v²/2a` while braking,
    /// so `v = −a·t_r + √((a·t_r)² + 2a·(d − d_stop))`, and 0 inside the stop distance.
    fn forward_speed_cap_m_s(&self, distance_m: f64) -> f64 {
        self.stopping_speed_m_s(distance_m - self.params.stop_distance_m)
    }

    /// The speed (m/s) from which the vehicle stops within `room_m` (0 for no room), braking at
    /// `brake_decel_m_s2` after `reaction_time_s`.
    fn stopping_speed_m_s(&self, room_m: f64) -> f64 {
        let p = &self.params;
        let braking = Braking { decel_m_s2: p.brake_decel_m_s2, latency_s: p.reaction_time_s, margin_m: 0.0 };
        // The parameters are validated and `room_m` comes from finite depths, so a refusal
        // cannot happen; were it to, no room is the safe answer.
        braking.speed_cap_m_s(room_m.max(0.0)).unwrap_or(0.0)
    }

    /// `V_in`: the desired speed as a share of the maximum, 0..1.
    fn speed_input(&self) -> f64 {
        (self.desired_speed_m_s / self.params.max_speed_m_s).clamp(0.0, 1.0)
    }

    /// Health with only the counters set.
    fn counters(&self) -> AvoidanceHealth {
        AvoidanceHealth {
            grids_rejected: self.grids_rejected,
            setpoints_rejected: self.setpoints_rejected,
            ..AvoidanceHealth::default()
        }
    }
}
