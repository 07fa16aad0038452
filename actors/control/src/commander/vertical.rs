//! Vertical avoidance from single-beam rangefinders: the forward camera sees
//! nothing above or below the vehicle, so TAKEOFF's and RTL's climbs and LAND's descent were
//! flown blind.
//!
//! * **Overhead.** While the upward rangefinder sees a surface, no trajectory setpoint (every
//!   mode but STABILIZE and ACRO, which fly attitudes) may take the vehicle higher than
//!   `margin_m` below it: a position target is lowered to that ceiling, and a climb rate is cut
//!   to what stops in the gap left, `√(2·a·gap)`. This is ArduCopter's
//!   `AC_Avoid::adjust_velocity_z` (`AVOID_MARGIN` 2 m, 1 m/s² braking), applied here to
//!   autonomous setpoints too: ArduCopter does not call it in AUTO/GUIDED take-off or RTL's
//!   climb, and PX4's collision prevention is horizontal only. Inside the margin the vehicle
//!   holds and may not climb, but is not pushed down (ArduCopter backs away at `AVOID_BACKZ_SPD`):
//!   a stuck or dirty beam would otherwise drive it towards the ground in every mode. A
//!   take-off or RTL climb held by a ceiling seen for a second counts as done at it, so the
//!   vehicle does not hover under it for ever (ArduCopter's take-off never completes there); on the ground with
//!   less than a metre of room under the ceiling, TAKEOFF does not leave the ground.
//! * **Below.** A landing's descent reads the downward rangefinder. A surface under the vehicle
//!   more than `obstacle_below_m` above the take-off ground is an obstacle's top (a roof, a
//!   trunk), not a landing spot: the descent stops (at least `margin_m` above it) and the
//!   vehicle moves back along the way it was facing, the way it came, `land_shift_m` at a time,
//!   reading the beam only when level over each step, until the beam sees the ground, then one
//!   step more so the airframe clears the edge, and lands there. After `land_search_m`, when the
//!   downward rangefinder falls silent, or when `obstacle_below_m` is set to 0, it lands where
//!   it is (a controlled end rather than hovering until the battery fails). No return counts as
//!   ground only from higher above home than the sensor reaches. The ground is taken to be
//!   level with home: on a slope that rises more than `obstacle_below_m` under the landing, the
//!   vehicle moves on before landing. PX4 and ArduPilot only slow the
//!   last metres with a downward rangefinder (`MPC_LAND_ALT*`, `LAND_ALT_LOW`); the descent
//!   speed here also follows the nearer of the height above home and the rangefinder's.
//!
//! A reading older than `timeout_s` counts for nothing (no limit, no obstacle): without the
//! sensor the vehicle flies as it did before.

use kestrel_proto::Time;
use kestrel_proto::messages::{NavState, RangefinderOrientation, RangefinderSample, TrajectorySetpoint};
use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, non_negative, positive, within};

/// `[vertical]`: what the rangefinders make the commander do.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VerticalParams {
    /// Least distance kept below what is overhead, and above an obstacle's top while a
    /// landing moves off it (m); ArduPilot's `AVOID_MARGIN`.
    pub margin_m: f64,
    /// Braking the climb limit assumes (m/s²): ArduPilot's 1 m/s² (`AC_AVOID_ACCEL_CMSS_MAX`).
    pub climb_accel_m_s2: f64,
    /// A reading older than this counts for nothing (s).
    pub timeout_s: f64,
    /// A surface under a landing more than this above home is an obstacle's top (m); 0 turns
    /// the check off.
    pub obstacle_below_m: f64,
    /// How far a landing moves off an obstacle's top at a time (m).
    pub land_shift_m: f64,
    /// How far in all a landing moves before it lands where it is (m).
    pub land_search_m: f64,
}

impl Default for VerticalParams {
    fn default() -> Self {
        VerticalParams {
            margin_m: 2.0,
            climb_accel_m_s2: 1.0,
            timeout_s: 0.5,
            obstacle_below_m: 1.5,
            land_shift_m: 2.0,
            land_search_m: 12.0,
        }
    }
}

impl VerticalParams {
    pub(crate) fn validate(&self) -> Result<(), InvalidParam> {
        within("vertical.margin_m", self.margin_m, 0.2, 10.0)?;
        positive("vertical.climb_accel_m_s2", self.climb_accel_m_s2)?;
        within("vertical.timeout_s", self.timeout_s, 0.02, 10.0)?;
        non_negative("vertical.obstacle_below_m", self.obstacle_below_m)?;
        within("vertical.land_shift_m", self.land_shift_m, 0.5, 20.0)?;
        within("vertical.land_search_m", self.land_search_m, 0.0, 200.0)
    }
}

/// The newest reading of one rangefinder.
#[derive(Clone, Copy, Debug)]
struct Reading {
    time: Time,
    /// Along the beam (m); `None`: nothing within the sensor's range.
    distance_m: Option<f64>,
    /// The sensor's longest distance (m).
    max_range_m: f64,
}

/// What the downward beam says now.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Below {
    /// Vertical distance to the surface it sees (m); `None`: nothing within its range.
    pub distance_m: Option<f64>,
    /// The sensor's longest distance (m).
    pub max_range_m: f64,
    /// The vehicle is level enough (within about 25°) for the beam to fall near straight below
    /// it; braking tilts it and the beam reads the ground ahead.
    pub level: bool,
}

/// The up- and downward rangefinders' newest readings.
#[derive(Clone, Debug, Default)]
pub(crate) struct Rangefinders {
    up: Option<Reading>,
    down: Option<Reading>,
    /// Since when the upward beam has seen a surface in every reading.
    overhead_since: Option<Time>,
}

/// A ceiling counts for ending a climb (a take-off, RTL's climb, a mission item reached at it)
/// once the upward beam has seen it this long (s): a passing return, a bird or a branch swaying
/// through the beam, only holds the climb while it lasts.
const STEADY_CEILING_S: f64 = 1.0;

impl Rangefinders {
    /// Takes a sample in; a bad one is refused with the reason and changes nothing.
    pub fn on_sample(&mut self, sample: &RangefinderSample) -> Result<(), String> {
        if let Some(why) = sample.invalid() {
            return Err(why);
        }
        let reading = Some(Reading {
            time: sample.time,
            distance_m: sample.distance_m,
            max_range_m: sample.max_range_m,
        });
        match sample.orientation {
            RangefinderOrientation::Up => {
                self.up = reading;
                self.overhead_since = sample.distance_m.and(self.overhead_since.or(Some(sample.time)));
            }
            RangefinderOrientation::Down => self.down = reading,
        }
        Ok(())
    }

    /// The vertical distance (m) to the surface the beam sees, from a reading fresh at `now`:
    /// `Some(None)` when nothing is within its range, `None` without a fresh reading. The beam
    /// is fixed to the airframe, so a tilt lengthens it: the vertical part is the beam's length
    /// times the cosine of the tilt.
    fn vertical_m(
        &self,
        which: RangefinderOrientation,
        now: Time,
        nav: &NavState,
        timeout_s: f64,
    ) -> Option<Option<f64>> {
        let reading = match which {
            RangefinderOrientation::Up => self.up,
            RangefinderOrientation::Down => self.down,
        }?;
        if now.saturating_since(reading.time).as_secs_f64() > timeout_s {
            return None;
        }
        // Past 90° of tilt the beam points the other way: no reading at all.
        let cos_tilt = cos_tilt(nav);
        if cos_tilt <= 0.0 {
            return None;
        }
        Some(reading.distance_m.map(|d| d * cos_tilt))
    }

    /// The highest the vehicle may be (NED down, m): `margin_m` below what the upward beam sees.
    pub fn ceiling_down_m(&self, now: Time, nav: &NavState, p: &VerticalParams) -> Option<f64> {
        let above = self.vertical_m(RangefinderOrientation::Up, now, nav, p.timeout_s)??;
        Some(nav.position_ned_m[2] - above + p.margin_m)
    }

    /// [`Rangefinders::ceiling_down_m`] once the surface overhead has been seen for
    /// [`STEADY_CEILING_S`]: where a climb may end.
    pub fn steady_ceiling_down_m(&self, now: Time, nav: &NavState, p: &VerticalParams) -> Option<f64> {
        let since = self.overhead_since?;
        (now.saturating_since(since).as_secs_f64() >= STEADY_CEILING_S)
            .then(|| self.ceiling_down_m(now, nav, p))
            .flatten()
    }

    /// The vertical distance to the surface under the vehicle (m), if the downward beam sees one.
    pub fn below_m(&self, now: Time, nav: &NavState, p: &VerticalParams) -> Option<f64> {
        self.below(now, nav, p)?.distance_m
    }

    /// The downward beam's fresh reading, `None` without one.
    pub fn below(&self, now: Time, nav: &NavState, p: &VerticalParams) -> Option<Below> {
        let distance_m = self.vertical_m(RangefinderOrientation::Down, now, nav, p.timeout_s)?;
        let max_range_m = self.down.map_or(0.0, |r| r.max_range_m);
        Some(Below { distance_m, max_range_m, level: cos_tilt(nav) >= LEVEL_COS_TILT })
    }
}

/// cos 25°: tilted further, the downward beam's reading is not taken as what is below.
const LEVEL_COS_TILT: f64 = 0.906;

/// The cosine of the vehicle's tilt: R₂₂ of its body → NED rotation.
fn cos_tilt(nav: &NavState) -> f64 {
    let [_, x, y, _] = nav.attitude;
    1.0 - 2.0 * (x * x + y * y)
}

/// Keeps `sp` from taking a vehicle at `down_m` (NED, m) above `ceiling_down_m`: a position
/// target no higher than the ceiling (nor, inside the margin, than where the vehicle is), a
/// climb no faster than stops in the gap and none inside the margin. Whether it changed
/// anything.
pub(crate) fn hold_below(
    sp: &mut TrajectorySetpoint,
    down_m: f64,
    ceiling_down_m: f64,
    p: &VerticalParams,
) -> bool {
    let mut changed = false;
    let highest = ceiling_down_m.min(down_m);
    if let Some(target) = &mut sp.position_ned_m[2]
        && *target < highest
    {
        *target = highest;
        changed = true;
    }
    let gap = (down_m - ceiling_down_m).max(0.0);
    let least_down_m_s = -(2.0 * p.climb_accel_m_s2 * gap).sqrt();
    if let Some(v) = &mut sp.velocity_ned_m_s[2]
        && *v < least_down_m_s
    {
        *v = least_down_m_s;
        changed = true;
    }
    changed
}

/// A landing moving off an obstacle's top.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct LandingSearch {
    /// The landing spot (north, east, m), taken when the search first reads the beam: a
    /// mission's LAND item without a place resolves to wherever the vehicle is, which must not
    /// move with it.
    pub spot_ne_m: Option<[f64; 2]>,
    /// Added to the landing spot (north, east, m).
    pub offset_ne_m: [f64; 2],
    /// The way it moves (north, east unit vector), set when the top is first seen.
    direction_ne: Option<[f64; 2]>,
    /// Held height while moving (NED down, m).
    pub hold_down_m: Option<f64>,
    /// How far it has moved in all (m).
    moved_m: f64,
    /// The ground was seen: one more step is under way, then the descent.
    clearing: bool,
    /// Moved off (or gave up): descend.
    pub done: bool,
    /// The top's height below the vehicle when last seen (m), for the status.
    pub below_m: Option<f64>,
}

/// Within this of the shifted spot (m) the vehicle counts as there and reads the beam again.
const AT_SPOT_M: f64 = 0.4;

impl LandingSearch {
    /// One step of the search at `nav` over the spot `spot_ne` (without the offset; latched on
    /// the first step), the downward beam reading `below` (`None`: no fresh reading), home at
    /// `home_down_m`, the vehicle facing `yaw_rad`. Moves the offset and the held height; sets
    /// `done`.
    pub fn step(
        &mut self,
        nav: &NavState,
        spot_ne: [f64; 2],
        below: Option<Below>,
        home_down_m: f64,
        yaw_rad: f64,
        p: &VerticalParams,
    ) {
        if self.done {
            return;
        }
        let Some(below) = below.filter(|_| p.obstacle_below_m > 0.0) else {
            // The sensor fell silent or the check was turned off: land here.
            if self.searching() {
                tracing::warn!("landing: no downward rangefinder (or LAND_OBS_HGT_M 0), landing here");
                self.finish();
            }
            return;
        };
        if !below.level {
            return;
        }
        let spot = *self.spot_ne_m.get_or_insert(spot_ne);
        let [n, e, down] = nav.position_ned_m;
        let height_m = home_down_m - down;
        let surface_height_m = below.distance_m.map(|b| height_m - b);
        let on_top = surface_height_m.is_some_and(|h| h > p.obstacle_below_m);
        // Nothing in range is the ground only from higher up than the sensor reaches.
        let over_ground = match surface_height_m {
            Some(h) => h <= p.obstacle_below_m,
            None => height_m > below.max_range_m,
        };
        let target = [spot[0] + self.offset_ne_m[0], spot[1] + self.offset_ne_m[1]];
        let there = (n - target[0]).hypot(e - target[1]) < AT_SPOT_M;
        if on_top {
            self.below_m = below.distance_m;
            let top_down_m = down + below.distance_m.unwrap_or(0.0);
            let hold = (top_down_m - p.margin_m).min(self.hold_down_m.unwrap_or(down));
            self.hold_down_m = Some(hold);
            self.clearing = false;
            if self.direction_ne.is_none() || there {
                let direction = *self.direction_ne.get_or_insert([-yaw_rad.cos(), -yaw_rad.sin()]);
                if self.moved_m + p.land_shift_m > p.land_search_m {
                    tracing::warn!(moved_m = self.moved_m, "landing: no clear ground found, landing here");
                    self.finish();
                    return;
                }
                self.shift(direction, p.land_shift_m);
            }
        } else if let Some(direction) = self.direction_ne.filter(|_| over_ground && there) {
            // Moved off the top, over the ground: one step more to clear the edge, then land.
            if self.clearing {
                self.finish();
            } else {
                self.clearing = true;
                self.shift(direction, p.land_shift_m);
            }
        }
    }

    fn finish(&mut self) {
        self.done = true;
        self.below_m = None;
    }

    fn shift(&mut self, direction: [f64; 2], step_m: f64) {
        self.offset_ne_m[0] += direction[0] * step_m;
        self.offset_ne_m[1] += direction[1] * step_m;
        self.moved_m += step_m;
    }

    /// Still moving off a top (the descent waits).
    pub fn searching(&self) -> bool {
        self.direction_ne.is_some() && !self.done
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::attitude::quaternion_from_euler;

    use super::*;

    fn nav_at(down_m: f64, roll_rad: f64) -> NavState {
        NavState {
            attitude: quaternion_from_euler(roll_rad, 0.0, 0.0),
            ..crate::commander::tests::nav(Time::from_secs_f64(10.0), down_m, false)
        }
    }

    fn sample(
        orientation: RangefinderOrientation,
        time_s: f64,
        distance_m: Option<f64>,
    ) -> RangefinderSample {
        RangefinderSample {
            time: Time::from_secs_f64(time_s),
            orientation,
            distance_m,
            min_range_m: 0.1,
            max_range_m: 12.0,
        }
    }

    #[test]
    fn the_ceiling_is_the_margin_below_the_surface_overhead_measured_vertically() {
        let p = VerticalParams::default();
        let mut r = Rangefinders::default();
        r.on_sample(&sample(RangefinderOrientation::Up, 10.0, Some(5.0))).unwrap();
        let now = Time::from_secs_f64(10.1);
        // 3 m up, a surface 5 m above: the vehicle may rise to 6 m.
        assert!((r.ceiling_down_m(now, &nav_at(-3.0, 0.0), &p).unwrap() - -6.0).abs() < 1e-9);
        // Rolled 60°: the beam's 5 m are 2.5 m straight up.
        let tilted = r.ceiling_down_m(now, &nav_at(-3.0, 60f64.to_radians()), &p).unwrap();
        assert!((tilted - (-3.0 - 2.5 + 2.0)).abs() < 1e-9, "{tilted}");
        // Stale: no limit. Nothing in range: no limit.
        assert_eq!(r.ceiling_down_m(Time::from_secs_f64(10.6), &nav_at(-3.0, 0.0), &p), None);
        r.on_sample(&sample(RangefinderOrientation::Up, 10.0, None)).unwrap();
        assert_eq!(r.ceiling_down_m(now, &nav_at(-3.0, 0.0), &p), None);
    }

    #[test]
    fn bad_samples_are_refused_and_leave_the_last_good_one() {
        let mut r = Rangefinders::default();
        r.on_sample(&sample(RangefinderOrientation::Down, 10.0, Some(4.0))).unwrap();
        for d in [f64::NAN, f64::INFINITY, -1.0, 40.0] {
            assert!(r.on_sample(&sample(RangefinderOrientation::Down, 10.05, Some(d))).is_err(), "{d}");
        }
        let p = VerticalParams::default();
        assert_eq!(r.below_m(Time::from_secs_f64(10.1), &nav_at(-4.0, 0.0), &p), Some(4.0));
    }

    #[test]
    fn a_climb_is_cut_to_what_stops_in_the_gap_and_a_target_above_the_ceiling_is_lowered() {
        let p = VerticalParams::default();
        let mut sp = TrajectorySetpoint {
            position_ned_m: [Some(0.0), Some(0.0), Some(-10.0)],
            velocity_ned_m_s: [None, None, Some(-3.0)],
            ..TrajectorySetpoint::default()
        };
        // At 3 m, ceiling at 5 m: 2 m of gap allow √(2·1·2) = 2 m/s up.
        assert!(hold_below(&mut sp, -3.0, -5.0, &p));
        assert_eq!(sp.position_ned_m[2], Some(-5.0));
        assert!((sp.velocity_ned_m_s[2].unwrap() - -2.0).abs() < 1e-12);
        // Inside the margin (0.5 m above the ceiling): no climb, no push down, a target above
        // held where the vehicle is.
        let mut sp = TrajectorySetpoint {
            position_ned_m: [None, None, Some(-8.0)],
            velocity_ned_m_s: [None, None, Some(-1.0)],
            ..TrajectorySetpoint::default()
        };
        assert!(hold_below(&mut sp, -5.5, -5.0, &p));
        assert_eq!((sp.position_ned_m[2], sp.velocity_ned_m_s[2]), (Some(-5.5), Some(0.0)));
        let mut sp =
            TrajectorySetpoint { velocity_ned_m_s: [None, None, Some(0.0)], ..TrajectorySetpoint::default() };
        assert!(!hold_below(&mut sp, -5.5, -5.0, &p));
        // Below the ceiling and descending: untouched.
        let mut sp = TrajectorySetpoint {
            position_ned_m: [None, None, Some(-2.0)],
            velocity_ned_m_s: [None, None, Some(0.5)],
            ..TrajectorySetpoint::default()
        };
        let before = sp;
        assert!(!hold_below(&mut sp, -3.0, -5.0, &p));
        assert_eq!(sp, before);
    }

    proptest::proptest! {
        /// Whatever the setpoint, after the limit a position target is at or below the ceiling
        /// (or, inside the margin, where the vehicle is), never pushed below both, and a
        /// vertical rate never climbs faster than stops in the gap (not at all inside the
        /// margin) and is never made a descent.
        #[test]
        fn no_limited_setpoint_climbs_past_the_ceiling(
            target in proptest::option::of(-50.0f64..5.0),
            rate in proptest::option::of(-5.0f64..5.0),
            down in -30.0f64..0.0,
            ceiling in -30.0f64..0.0,
        ) {
            let p = VerticalParams::default();
            let mut sp = TrajectorySetpoint {
                position_ned_m: [None, None, target],
                velocity_ned_m_s: [None, None, rate],
                ..TrajectorySetpoint::default()
            };
            hold_below(&mut sp, down, ceiling, &p);
            if let (Some(t), Some(asked)) = (sp.position_ned_m[2], target) {
                proptest::prop_assert!(t >= ceiling.min(down));
                proptest::prop_assert!(t <= asked.max(ceiling.min(down)));
            }
            if let (Some(v), Some(asked)) = (sp.velocity_ned_m_s[2], rate) {
                let gap = (down - ceiling).max(0.0);
                proptest::prop_assert!(v >= -(2.0 * gap).sqrt() - 1e-12);
                proptest::prop_assert!(v <= asked.max(0.0));
            }
        }
    }

    /// A level reading of a 12 m sensor: `distance_m` below, or nothing in range.
    fn seen(distance_m: Option<f64>) -> Option<Below> {
        Some(Below { distance_m, max_range_m: 12.0, level: true })
    }

    #[test]
    fn a_landing_over_a_top_holds_moves_back_past_the_edge_then_lands() {
        let p = VerticalParams::default();
        let mut s = LandingSearch::default();
        // 10 m up facing north, a 4 m top under the vehicle (6 m below it).
        let mut nav = nav_at(-10.0, 0.0);
        s.step(&nav, [0.0, 0.0], seen(Some(6.0)), 0.0, 0.0, &p);
        assert!(s.searching());
        assert_eq!(s.hold_down_m, Some(-10.0));
        assert_eq!(s.offset_ne_m, [-2.0, 0.0]);
        // Not there yet: nothing moves.
        s.step(&nav, [0.0, 0.0], seen(Some(6.0)), 0.0, 0.0, &p);
        assert_eq!(s.offset_ne_m, [-2.0, 0.0]);
        // There, still over the top: another step.
        nav.position_ned_m = [-2.0, 0.0, -10.0];
        s.step(&nav, [0.0, 0.0], seen(Some(6.0)), 0.0, 0.0, &p);
        assert_eq!(s.offset_ne_m, [-4.0, 0.0]);
        // There, over the ground: one step more to clear the edge, then done.
        nav.position_ned_m = [-4.0, 0.0, -10.0];
        s.step(&nav, [0.0, 0.0], seen(Some(10.0)), 0.0, 0.0, &p);
        assert_eq!(s.offset_ne_m, [-6.0, 0.0]);
        assert!(s.searching());
        nav.position_ned_m = [-6.0, 0.0, -10.0];
        s.step(&nav, [0.0, 0.0], seen(Some(10.0)), 0.0, 0.0, &p);
        assert!(s.done && !s.searching());
    }

    #[test]
    fn the_ground_below_is_no_obstacle_and_a_search_that_finds_no_ground_lands_where_it_is() {
        let p = VerticalParams { land_search_m: 4.0, ..VerticalParams::default() };
        let mut s = LandingSearch::default();
        let mut nav = nav_at(-10.0, 0.0);
        // The ground 10 m below, and a top 1 m high (under obstacle_below_m): no search.
        s.step(&nav, [0.0, 0.0], seen(Some(10.0)), 0.0, 0.0, &p);
        s.step(&nav, [0.0, 0.0], seen(Some(9.0)), 0.0, 0.0, &p);
        assert!(!s.searching() && s.offset_ne_m == [0.0, 0.0]);
        // Over a wide roof, facing east: back west 2 m, 4 m, then gives up.
        s.step(&nav, [0.0, 0.0], seen(Some(6.0)), 0.0, std::f64::consts::FRAC_PI_2, &p);
        assert!((s.offset_ne_m[1] - -2.0).abs() < 1e-12);
        nav.position_ned_m = [0.0, -2.0, -10.0];
        s.step(&nav, [0.0, 0.0], seen(Some(6.0)), 0.0, 0.0, &p);
        nav.position_ned_m = [0.0, -4.0, -10.0];
        s.step(&nav, [0.0, 0.0], seen(Some(6.0)), 0.0, 0.0, &p);
        assert!(s.done);
    }

    #[test]
    fn a_silent_sensor_or_the_check_turned_off_mid_search_lands_there_and_a_tilted_reading_waits() {
        let p = VerticalParams::default();
        let nav = nav_at(-10.0, 0.0);
        let mut s = LandingSearch::default();
        s.step(&nav, [0.0, 0.0], seen(Some(6.0)), 0.0, 0.0, &p);
        assert!(s.searching());
        // Tilted: no judgement, the search goes on.
        s.step(&nav, [0.0, 0.0], Some(Below { level: false, ..seen(Some(10.0)).unwrap() }), 0.0, 0.0, &p);
        assert!(s.searching());
        s.step(&nav, [0.0, 0.0], None, 0.0, 0.0, &p);
        assert!(s.done && !s.searching());
        let mut s = LandingSearch::default();
        s.step(&nav, [0.0, 0.0], seen(Some(6.0)), 0.0, 0.0, &p);
        let off = VerticalParams { obstacle_below_m: 0.0, ..VerticalParams::default() };
        s.step(&nav, [0.0, 0.0], seen(Some(6.0)), 0.0, 0.0, &off);
        assert!(s.done);
    }

    #[test]
    fn the_spot_is_latched_and_no_return_is_ground_only_from_out_of_the_sensors_reach() {
        let p = VerticalParams::default();
        let mut s = LandingSearch::default();
        let mut nav = nav_at(-10.0, 0.0);
        s.step(&nav, [0.0, 0.0], seen(Some(6.0)), 0.0, 0.0, &p);
        // A spot that moves with the vehicle (a LAND item without a place) is not followed.
        nav.position_ned_m = [-2.0, 0.0, -10.0];
        s.step(&nav, [-2.0, 0.0], seen(Some(6.0)), 0.0, 0.0, &p);
        assert_eq!((s.spot_ne_m, s.offset_ne_m), (Some([0.0, 0.0]), [-4.0, 0.0]));
        // 10 m up with a 12 m sensor, nothing in range: not the ground (a dark roof), wait.
        nav.position_ned_m = [-4.0, 0.0, -10.0];
        s.step(&nav, [0.0, 0.0], seen(None), 0.0, 0.0, &p);
        assert_eq!(s.offset_ne_m, [-4.0, 0.0]);
        // 14 m up, nothing in range: the ground, out of reach; one step more.
        nav.position_ned_m = [-4.0, 0.0, -14.0];
        s.step(&nav, [0.0, 0.0], seen(None), 0.0, 0.0, &p);
        assert_eq!(s.offset_ne_m, [-6.0, 0.0]);
    }
}
