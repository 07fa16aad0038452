//! Short-term obstacle memory: what the camera saw, kept in the local NED frame so that the
//! avoider still knows about a trunk once it has left the 110° view.
//!
//! Why: the camera looks forward only, but the avoider's corrections (a sidestep, the rule
//! base's lateral steer, the low-pass's tail) move the vehicle sideways. In the forest of
//! `config/worlds/forest.toml` every collision without memory was a trunk beside the vehicle,
//! seen seconds earlier and out of view when it was hit. PX4's collision prevention keeps its
//! 72 bins for directions outside the sensor's view for the same reason (`CP_GO_NO_DATA`);
//! VFH+ builds its polar histogram from a local map, not from the last scan.
//!
//! Each accepted depth grid's `OBSTACLE_DISTANCE` sectors (horizontal ranges at the vehicle's
//! level, 5° each) are placed in NED with the estimator's pose at capture time. A newer frame
//! replaces what it sees: a remembered point in a sector the frame measures (with both its
//! neighbours), nearer than their range plus [`CARVE_TOLERANCE_M`], is either seen again or
//! proven gone, and is dropped; points behind the measured range (occluded) and outside the view stay. Points are
//! forgotten `memory_time_s` after they were last seen or last within `keep_within_m` of the
//! vehicle (a trunk the vehicle hovers beside is not forgotten while it hovers: one forgotten
//! during a long hover is slid into; decision 0038), beyond `memory_range_m`,
//! and are ignored while the vehicle flies more than `memory_height_m` above or below the
//! height it saw them from (after a climb over a wall, the wall is below).
//!
//! The memory then limits the vehicle's horizontal velocity: towards every remembered point,
//! the velocity component may not exceed the speed from which the vehicle can still stop
//! `memory_stop_distance_m` short of it. The limit removes only the component towards the
//! obstacle, so the vehicle slides past it rather than stopping.
//!
//! Storage is a fixed-capacity vector made once; no step allocates.

use kestrel_proto::Time;
use kestrel_proto::messages::{NavState, ObstacleSectors, SECTOR_UNKNOWN};

/// A remembered point at a sector's measured range within this much (m) of what a newer frame
/// measures in the same sector counts as seen again and is replaced by the new one: about a
/// trunk's radius plus the stereo range error at a few metres.
pub const CARVE_TOLERANCE_M: f64 = 0.3;

/// Points the memory holds at most; the oldest go first. A frame adds at most one point per
/// 5° sector in view (23 for the 110° camera) and replaces those it sees again, so the memory
/// holds mostly what is out of view: a few hundred points in the densest forest.
pub const CAPACITY: usize = 2048;

/// The vehicle's position and heading at one instant, from the estimator (local NED).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// When the estimate was valid.
    pub time: Time,
    /// Position north, east, down of the local origin (m).
    pub ned_m: [f64; 3],
    /// Heading, clockwise from north (rad).
    pub yaw_rad: f64,
}

impl Pose {
    /// The pose of an estimator state, `None` unless its position (horizontal and vertical)
    /// and attitude are valid and finite: what the memory holds could not be placed with it.
    pub fn from_nav(nav: &NavState) -> Option<Pose> {
        let valid = nav.valid.horizontal_position && nav.valid.attitude && nav.valid.vertical_position;
        if !valid || !nav.position_ned_m.iter().chain(&nav.attitude).all(|v| v.is_finite()) {
            return None;
        }
        let [w, x, y, z] = nav.attitude;
        let yaw_rad = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
        Some(Pose { time: nav.time, ned_m: nav.position_ned_m, yaw_rad })
    }

    /// The horizontal body-frame bearing (rad, clockwise from forward) and range (m) of a NED
    /// point.
    fn bearing_range(&self, north_m: f64, east_m: f64) -> (f64, f64) {
        let (dn, de) = (north_m - self.ned_m[0], east_m - self.ned_m[1]);
        ((de.atan2(dn) - self.yaw_rad), dn.hypot(de))
    }
}

/// How the memory keeps and uses what it saw.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MemorySettings {
    /// Points older than this are forgotten (s).
    pub time_s: f64,
    /// Only sector ranges up to this are remembered, and points farther than this from the
    /// vehicle are forgotten (m).
    pub range_m: f64,
    /// Points seen from a height more than this above or below the vehicle's are ignored (m).
    pub height_m: f64,
    /// Points within this horizontal distance of the vehicle do not age (m): what is near
    /// enough to close a side to the sidestep stays known however long the vehicle stays by it.
    pub keep_within_m: f64,
    /// How far (m) a sector straight ahead (within [`AHEAD_HALF_WIDTH_RAD`]) that the frame
    /// could not measure still vouches for free space; 0: an unmeasured sector says nothing.
    /// Set while the ground is out of the stereo pair's reach, where an invalid view counts as
    /// clear up to the avoider's `unknown_range_m`: a point the frame cannot confirm ahead is
    /// then dropped as if seen through, as the speed cap already trusts that range. Without
    /// it, the rim of a 25 m tree top seen 2 m below, placed at the vehicle's level 1 m ahead,
    /// held the vehicle above the tree for good, where no later frame could see it again.
    pub unmeasured_clear_m: f64,
}

/// Half the width of the directions straight ahead that every forward camera sees (rad): the
/// only ones where an unmeasured sector may vouch for free space (`unmeasured_clear_m`).
/// Sectors outside the view are unmeasured too, and must keep what is beside the vehicle.
pub const AHEAD_HALF_WIDTH_RAD: f64 = 15.0 * std::f64::consts::PI / 180.0;

/// One remembered obstacle point.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Point {
    north_m: f64,
    east_m: f64,
    /// The vehicle's down position when the point was seen (m): the sectors are measured at
    /// the vehicle's level.
    seen_down_m: f64,
    /// When the point was last seen or last within `keep_within_m` of the vehicle: its age
    /// counts from then.
    kept: Time,
}

/// The remembered obstacle points (see the module docs).
#[derive(Debug, Clone)]
pub struct ObstacleMemory {
    points: Vec<Point>,
}

impl Default for ObstacleMemory {
    fn default() -> ObstacleMemory {
        ObstacleMemory::new()
    }
}

impl ObstacleMemory {
    /// An empty memory with room for [`CAPACITY`] points.
    pub fn new() -> ObstacleMemory {
        ObstacleMemory { points: Vec::with_capacity(CAPACITY) }
    }

    /// Points held now.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether no point is held.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Forgets everything (no pose, or the estimate's position became invalid).
    pub fn clear(&mut self) {
        self.points.clear();
    }

    /// Takes in one frame's `sectors`, captured at `pose`: forgets what is too old or too far
    /// from it, drops what the frame sees again or sees through, and remembers each measured
    /// sector range up to `settings.range_m`.
    pub fn observe(&mut self, sectors: &ObstacleSectors, pose: &Pose, settings: &MemorySettings) {
        let count = sectors.distances_cm.len();
        let increment = f64::from(sectors.increment_deg).to_radians();
        if count == 0 || !(increment.is_finite() && increment > 0.0) {
            return;
        }
        let offset = f64::from(sectors.angle_offset_deg).to_radians();
        // A sector's measured range (m): `None` where it has no data; "free up to the maximum"
        // reads as the maximum.
        let measured = |index: usize| -> Option<f64> {
            let cm = sectors.distances_cm[index];
            (cm != SECTOR_UNKNOWN).then(|| f64::from(cm.min(sectors.max_distance_cm)) / 100.0)
        };
        let sector_of = |bearing_rad: f64| -> usize {
            (((bearing_rad - offset) / increment).round() as i64).rem_euclid(count as i64) as usize
        };
        // What a frame says about a direction: the nearest range of its sector and both
        // neighbours, and nothing unless all three were measured. A sector at the edge of the
        // view is measured only in part (the matcher finds no disparity in the left image's
        // first columns), so a point that has slid out of the measured part must not be taken
        // as seen through (a trunk forgotten that way is flown into).
        let vouched = |index: usize| -> Option<f64> {
            let ahead = angle_between(offset + index as f64 * increment, 0.0) <= AHEAD_HALF_WIDTH_RAD;
            measured(index)
                .or((ahead && settings.unmeasured_clear_m > 0.0).then_some(settings.unmeasured_clear_m))
        };
        let covering = |sector: usize| -> Option<f64> {
            [count - 1, 0, 1]
                .iter()
                .map(|&step| vouched((sector + step) % count))
                .try_fold(f64::INFINITY, |nearest, m| m.map(|m| nearest.min(m)))
        };
        self.points.retain_mut(|p| {
            let (bearing, range) = pose.bearing_range(p.north_m, p.east_m);
            if range <= settings.keep_within_m {
                p.kept = p.kept.max(pose.time);
            }
            let fresh = pose.time.saturating_since(p.kept).as_secs_f64() <= settings.time_s;
            let seen_again = covering(sector_of(bearing)).is_some_and(|m| range < m + CARVE_TOLERANCE_M);
            fresh && range <= settings.range_m && !seen_again
        });
        for index in 0..count {
            let Some(range) = sectors.obstacle_m(index).filter(|&range| range <= settings.range_m) else {
                continue;
            };
            if self.points.len() == CAPACITY {
                self.points.remove(0);
            }
            let (sin, cos) = (pose.yaw_rad + offset + index as f64 * increment).sin_cos();
            self.points.push(Point {
                north_m: pose.ned_m[0] + range * cos,
                east_m: pose.ned_m[1] + range * sin,
                seen_down_m: pose.ned_m[2],
                kept: pose.time,
            });
        }
    }

    /// The remembered points that apply at `pose` (within `settings.height_m` of the height
    /// they were seen from), as body-frame `(bearing rad clockwise from forward, range m)`.
    pub fn around<'a>(
        &'a self,
        pose: &'a Pose,
        settings: &'a MemorySettings,
    ) -> impl Iterator<Item = (f64, f64)> + 'a {
        self.points
            .iter()
            .filter(|p| (p.seen_down_m - pose.ned_m[2]).abs() <= settings.height_m)
            .map(|p| pose.bearing_range(p.north_m, p.east_m))
    }

    /// Nearest remembered range (m) within `half_width_rad` of the body bearing `bearing_rad`
    /// (clockwise from forward), if any.
    pub fn nearest_towards(
        &self,
        pose: &Pose,
        settings: &MemorySettings,
        bearing_rad: f64,
        half_width_rad: f64,
    ) -> Option<f64> {
        self.around(pose, settings)
            .filter(|&(b, _)| angle_between(b, bearing_rad) <= half_width_rad)
            .map(|(_, range)| range)
            .min_by(f64::total_cmp)
    }

    /// Limits the horizontal body-frame velocity `[forward, right]` (m/s) so that its
    /// component towards each remembered point is at most `cap(range)`, the speed from which
    /// the vehicle can still stop short of a point that far (`cap` ≥ 0). Returns the limited
    /// velocity and whether any point limited it.
    ///
    /// Each limit is a half-plane of velocities containing zero; projecting on them in turn
    /// (POCS) removes only the component towards each point, so the vehicle slides past an
    /// obstacle rather than stopping. A few sweeps settle all but contrived layouts; whatever
    /// violation is left is removed by scaling the velocity down, which stays inside every
    /// half-plane because zero is inside all of them.
    pub fn limit(
        &self,
        pose: &Pose,
        settings: &MemorySettings,
        velocity_fr_m_s: [f64; 2],
        cap: impl Fn(f64) -> f64,
    ) -> ([f64; 2], bool) {
        const SWEEPS: usize = 4;
        const SLACK_M_S: f64 = 1e-9;
        let [mut forward, mut right] = velocity_fr_m_s;
        let mut limited = false;
        for _ in 0..SWEEPS {
            let mut changed = false;
            for (bearing, range) in self.around(pose, settings) {
                let (sin, cos) = bearing.sin_cos();
                let excess = forward * cos + right * sin - cap(range).max(0.0);
                if excess > SLACK_M_S {
                    forward -= excess * cos;
                    right -= excess * sin;
                    changed = true;
                }
            }
            limited |= changed;
            if !changed {
                return ([forward, right], limited);
            }
        }
        let mut scale: f64 = 1.0;
        for (bearing, range) in self.around(pose, settings) {
            let (sin, cos) = bearing.sin_cos();
            let towards = forward * cos + right * sin;
            if towards > SLACK_M_S {
                scale = scale.min(cap(range).max(0.0) / towards);
            }
        }
        ([forward * scale, right * scale], true)
    }
}

/// Absolute difference of two angles (rad), in 0..π.
fn angle_between(a: f64, b: f64) -> f64 {
    ((a - b + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI).abs()
}

#[cfg(test)]
mod tests {
    use kestrel_proto::messages::OBSTACLE_SECTORS;
    use proptest::prelude::*;
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};

    use super::*;

    const SETTINGS: MemorySettings = MemorySettings {
        time_s: 10.0,
        range_m: 6.0,
        height_m: 1.5,
        keep_within_m: 2.0,
        unmeasured_clear_m: 0.0,
    };

    fn pose(seconds: f64, north_m: f64, east_m: f64, yaw_deg: f64) -> Pose {
        Pose {
            time: Time::from_secs_f64(seconds),
            ned_m: [north_m, east_m, -5.0],
            yaw_rad: yaw_deg.to_radians(),
        }
    }

    /// Sectors of a 110° camera (±55°: sectors −11..=11) reading `free` everywhere in view but
    /// for the given `(sector, range m)`; a negative sector counts anticlockwise from forward.
    fn view(readings: &[(i32, f64)]) -> ObstacleSectors {
        let index = |s: i32| s.rem_euclid(OBSTACLE_SECTORS as i32) as usize;
        let free = (-11i32..=11).map(|s| (index(s), 2001));
        let read = readings.iter().map(|&(s, range)| (index(s), (range * 100.0).round() as u16));
        crate::avoidance::test_sectors(free.chain(read))
    }

    fn points(memory: &ObstacleMemory, at: &Pose) -> Vec<(f64, f64)> {
        memory.around(at, &SETTINGS).map(|(b, r)| (b.to_degrees(), r)).collect()
    }

    #[test]
    fn a_trunk_seen_ahead_is_remembered_beside_the_vehicle_after_a_turn() {
        let mut memory = ObstacleMemory::new();
        memory.observe(&view(&[(0, 3.0)]), &pose(0.0, 0.0, 0.0, 0.0), &SETTINGS);
        // Turned 90° right: the trunk (3 m north) is now abeam left, out of view.
        let turned = pose(1.0, 0.0, 0.0, 90.0);
        memory.observe(&view(&[]), &turned, &SETTINGS);
        let seen = points(&memory, &turned);
        assert_eq!(seen.len(), 1, "{seen:?}");
        assert!((seen[0].0 + 90.0).abs() < 1e-9 && (seen[0].1 - 3.0).abs() < 1e-9, "{seen:?}");
        assert_eq!(memory.nearest_towards(&turned, &SETTINGS, -FRAC_PI_2, FRAC_PI_4), Some(3.0));
        assert_eq!(memory.nearest_towards(&turned, &SETTINGS, FRAC_PI_2, FRAC_PI_4), None);
    }

    #[test]
    fn a_newer_frame_replaces_what_it_sees_and_keeps_what_is_hidden_behind() {
        let start = pose(0.0, 0.0, 0.0, 0.0);
        let mut memory = ObstacleMemory::new();
        memory.observe(&view(&[(2, 3.0)]), &start, &SETTINGS);
        // Seen again at the same range: one point, not two.
        memory.observe(&view(&[(2, 3.1)]), &pose(0.1, 0.0, 0.0, 0.0), &SETTINGS);
        assert_eq!(memory.len(), 1);
        // Something nearer in the same sector hides it: both are kept.
        memory.observe(&view(&[(2, 1.5)]), &pose(0.2, 0.0, 0.0, 0.0), &SETTINGS);
        assert_eq!(memory.len(), 2);
        // The sector reads free: seen through, both gone.
        memory.observe(&view(&[]), &pose(0.3, 0.0, 0.0, 0.0), &SETTINGS);
        assert!(memory.is_empty());
    }

    #[test]
    fn a_point_at_the_edge_of_the_measured_view_is_not_taken_as_seen_through() {
        // Sector −11 (the left edge) has no disparity; a trunk remembered in sector −10 is kept
        // although −10 now reads free: the edge sector is measured only in part.
        let mut edge = view(&[]);
        edge.distances_cm[61] = SECTOR_UNKNOWN;
        let mut memory = ObstacleMemory::new();
        let here = pose(0.0, 0.0, 0.0, 0.0);
        memory.observe(&view(&[(-10, 4.0)]), &here, &SETTINGS);
        memory.observe(&edge, &pose(0.1, 0.0, 0.0, 0.0), &SETTINGS);
        assert_eq!(memory.len(), 1);
        // Inside the view, with measured neighbours, a free reading drops it.
        memory.observe(&view(&[]), &pose(0.2, 0.0, 0.0, 0.0), &SETTINGS);
        assert!(memory.is_empty());
    }

    #[test]
    fn an_unmeasured_view_ahead_drops_points_straight_ahead_within_what_it_vouches_for_only() {
        // Seen 3 m ahead and 3 m ahead-right (45°); then nothing measured at all.
        let seen = pose(0.0, 0.0, 0.0, 0.0);
        let blank = ObstacleSectors { distances_cm: vec![SECTOR_UNKNOWN; OBSTACLE_SECTORS], ..view(&[]) };
        let remembered = || {
            let mut memory = ObstacleMemory::new();
            memory.observe(&view(&[(0, 3.0), (9, 3.0)]), &seen, &SETTINGS);
            memory
        };
        // An unmeasured sector says nothing by default: both stay.
        let mut memory = remembered();
        memory.observe(&blank, &pose(0.1, 0.0, 0.0, 0.0), &SETTINGS);
        assert_eq!(memory.len(), 2);
        // Vouching for 4 m: the point straight ahead goes, the one 45° off (out of the ±15°
        // every forward camera sees, as sectors outside the view are unmeasured too) stays.
        let vouching = MemorySettings { unmeasured_clear_m: 4.0, ..SETTINGS };
        let mut memory = remembered();
        memory.observe(&blank, &pose(0.1, 0.0, 0.0, 0.0), &vouching);
        let left = points(&memory, &seen);
        assert_eq!(left.len(), 1, "{left:?}");
        assert!((left[0].0 - 45.0).abs() < 1e-9, "{left:?}");
        // ... and only within what it vouches for: a point 5 m ahead stays.
        let mut memory = ObstacleMemory::new();
        memory.observe(&view(&[(0, 5.0)]), &seen, &SETTINGS);
        memory.observe(&blank, &pose(0.1, 0.0, 0.0, 0.0), &vouching);
        assert_eq!(memory.len(), 1);
    }

    #[test]
    fn points_are_forgotten_with_time_and_distance_and_ignored_at_another_height() {
        let mut memory = ObstacleMemory::new();
        memory.observe(&view(&[(0, 3.0)]), &pose(0.0, 0.0, 0.0, 0.0), &SETTINGS);
        let behind = pose(5.0, 5.5, 0.0, 0.0);
        memory.observe(&view(&[]), &behind, &SETTINGS);
        assert_eq!(memory.len(), 1, "2.5 m behind, out of view, 5 s old");
        let climbed = Pose { ned_m: [5.5, 0.0, -7.0], ..behind };
        assert_eq!(points(&memory, &climbed).len(), 0, "2 m above where it was seen from");
        memory.observe(&view(&[]), &pose(10.5, 5.5, 0.0, 0.0), &SETTINGS);
        assert!(memory.is_empty(), "10.5 s old");

        memory.observe(&view(&[(0, 3.0)]), &pose(20.0, 0.0, 0.0, 0.0), &SETTINGS);
        memory.observe(&view(&[]), &pose(20.1, 10.0, 0.0, 0.0), &SETTINGS);
        assert!(memory.is_empty(), "7 m away");
        memory.observe(&view(&[(0, 6.5)]), &pose(30.0, 0.0, 0.0, 0.0), &SETTINGS);
        assert!(memory.is_empty(), "beyond the 6 m range when seen");
    }

    #[test]
    fn a_point_beside_a_hovering_vehicle_does_not_age_until_the_vehicle_leaves_it() {
        // Seen 3 m ahead, then passed and hovered beside for 25 s (2.5 × `time_s`) 1.5 m from it.
        let mut memory = ObstacleMemory::new();
        memory.observe(&view(&[(0, 3.0)]), &pose(0.0, 0.0, 0.0, 0.0), &SETTINGS);
        for tenth in 1..=250 {
            memory.observe(&view(&[]), &pose(f64::from(tenth) / 10.0, 3.0, -1.5, 0.0), &SETTINGS);
        }
        let beside = pose(25.0, 3.0, -1.5, 0.0);
        assert_eq!(points(&memory, &beside).len(), 1, "kept while within 2 m");
        // 3 m away from then on: it ages from 25 s and is gone after 10 s more.
        memory.observe(&view(&[]), &pose(34.9, 3.0, -3.0, 0.0), &SETTINGS);
        assert_eq!(memory.len(), 1, "9.9 s since the vehicle was near");
        memory.observe(&view(&[]), &pose(35.1, 3.0, -3.0, 0.0), &SETTINGS);
        assert!(memory.is_empty(), "10.1 s since the vehicle was near");
    }

    #[test]
    fn a_full_memory_drops_its_oldest_points() {
        let mut memory = ObstacleMemory::new();
        let readings: Vec<(i32, f64)> = (-11..=11).map(|s| (s, 2.0)).collect();
        // Each frame from a new place 20 m further east, facing west: nothing of the earlier
        // frames is in view, and the range limit is lifted so nothing is forgotten by distance.
        let far = MemorySettings { range_m: 1e9, ..SETTINGS };
        for k in 0..200 {
            let at = Pose {
                time: Time::from_secs_f64(f64::from(k) * 0.01),
                ..pose(0.0, 0.0, f64::from(k) * 20.0, 270.0)
            };
            memory.observe(&view(&readings), &at, &far);
            assert!(memory.len() <= CAPACITY);
        }
        assert_eq!(memory.len(), CAPACITY);
    }

    fn cap(range_m: f64) -> f64 {
        (range_m - 1.0).max(0.0)
    }

    #[test]
    fn a_trunk_abeam_stops_the_slide_towards_it_and_leaves_forward_flight_alone() {
        let mut memory = ObstacleMemory::new();
        memory.observe(&view(&[(0, 1.5)]), &pose(0.0, 0.0, 0.0, 0.0), &SETTINGS);
        // Turned left: the trunk is abeam right, 1.5 m away: at most 0.5 m/s towards it.
        let now = pose(0.1, 0.0, 0.0, -90.0);
        let (v, limited) = memory.limit(&now, &SETTINGS, [3.0, 2.0], cap);
        assert!(limited);
        assert!((v[0] - 3.0).abs() < 1e-9 && (v[1] - 0.5).abs() < 1e-9, "{v:?}");
        let (away, limited) = memory.limit(&now, &SETTINGS, [3.0, -2.0], cap);
        assert!(!limited);
        assert_eq!(away, [3.0, -2.0]);
    }

    #[test]
    fn a_trunk_ahead_right_turns_the_velocity_left_keeping_its_tangential_part() {
        let mut memory = ObstacleMemory::new();
        let here = pose(0.0, 0.0, 0.0, 0.0);
        memory.observe(&view(&[(9, 1.2)]), &here, &SETTINGS);
        let (v, limited) = memory.limit(&here, &SETTINGS, [3.0, 0.0], cap);
        let (sin, cos) = 45f64.to_radians().sin_cos();
        assert!(limited);
        assert!((v[0] * cos + v[1] * sin - 0.2).abs() < 1e-9, "towards: {v:?}");
        assert!((v[0] * cos - v[1] * sin - 3.0 * cos).abs() < 1e-9, "tangential kept: {v:?}");
    }

    proptest! {
        #[test]
        fn the_limited_velocity_respects_every_remembered_point(
            readings in proptest::collection::vec((-11i32..=11, 0.4f64..6.0), 0..12),
            yaw_deg in -180.0f64..180.0,
            forward in -5.0f64..5.0,
            right in -5.0f64..5.0,
        ) {
            let mut memory = ObstacleMemory::new();
            memory.observe(&view(&readings), &pose(0.0, 0.0, 0.0, 0.0), &SETTINGS);
            let now = pose(0.1, 0.3, -0.2, yaw_deg);
            let (v, limited) = memory.limit(&now, &SETTINGS, [forward, right], cap);
            let mut violated = false;
            for (bearing, range) in memory.around(&now, &SETTINGS) {
                let (sin, cos) = bearing.sin_cos();
                prop_assert!(v[0] * cos + v[1] * sin <= cap(range) + 1e-6, "{v:?} towards {bearing} at {range}");
                violated |= forward * cos + right * sin > cap(range) + 1e-9;
            }
            prop_assert_eq!(limited, violated);
            if !violated {
                prop_assert_eq!(v, [forward, right]);
            }
            prop_assert!(v[0].hypot(v[1]) <= forward.hypot(right) + 1e-9, "never faster");
        }
    }
}
