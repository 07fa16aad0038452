//! Vertical avoidance from single-beam rangefinders (issue 20): the forward camera sees
//! nothing above or below the vehicle, so TAKEOFF's and RTL's climbs and LAND's descent were
//! flown blind.
//!
//! * **Overhead.** While the upward rangefinder sees a surface, no setpoint may take the
//!   vehicle higher than `margin_m` below it: a position target is lowered to that ceiling,
//!   and a climb rate is cut to what stops in the gap left, `√(2·a·gap)`; inside the margin the
//!   vehicle backs down at up to `backup_speed_m_s`. This is ArduCopter's
//!   `AC_Avoid::adjust_velocity_z` (`AVOID_MARGIN` 2 m, 1 m/s² braking, `AVOID_BACKZ_SPD`
//!   0.75 m/s), applied here to every setpoint, autonomous ones included: ArduCopter does not
//!   call it in AUTO/GUIDED take-off or RTL's climb, and PX4's collision prevention is
//!   horizontal only. A take-off or RTL climb held by a ceiling counts as done at it, so the
//!   vehicle does not hover under it for ever (ArduCopter's take-off never completes there).
//! * **Below.** A landing's descent reads the downward rangefinder. A surface under the vehicle
//!   more than `obstacle_below_m` above the take-off ground is an obstacle's top (a roof, a
//!   trunk), not a landing spot: the descent stops `margin_m` above it and the vehicle moves
//!   back along the way it was facing, `land_shift_m` at a time, until the beam sees the ground,
//!   then one step more so the airframe clears the edge, and lands there. After `land_search_m`
//!   it lands where it is (a controlled end rather than hovering until the battery fails). The
//!   ground is taken to be level with home: on a slope that rises more than `obstacle_below_m`
//!   under the landing, the vehicle moves on before landing. PX4 and ArduPilot only slow the
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
    /// Fastest descent back out of the margin (m/s); ArduPilot's `AVOID_BACKZ_SPD`.
    pub backup_speed_m_s: f64,
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
            backup_speed_m_s: 0.75,
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
        within("vertical.backup_speed_m_s", self.backup_speed_m_s, 0.0, 3.0)?;
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
}

/// The up- and downward rangefinders' newest readings.
#[derive(Clone, Debug, Default)]
pub(super) struct Rangefinders {
    up: Option<Reading>,
    down: Option<Reading>,
}

impl Rangefinders {
    /// Takes a sample in; a bad one is refused with the reason and changes nothing.
    pub fn on_sample(&mut self, sample: &RangefinderSample) -> Result<(), String> {
        if let Some(why) = sample.invalid() {
            return Err(why);
        }
        let reading = Some(Reading { time: sample.time, distance_m: sample.distance_m });
        match sample.orientation {
            RangefinderOrientation::Up => self.up = reading,
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
        let [_, x, y, _] = nav.attitude;
        // R₂₂ of body → NED: the cosine of the tilt.
        let cos_tilt = 1.0 - 2.0 * (x * x + y * y);
        Some(reading.distance_m.map(|d| d * cos_tilt.max(0.0)))
    }

    /// The highest the vehicle may be (NED down, m): `margin_m` below what the upward beam sees.
    pub fn ceiling_down_m(&self, now: Time, nav: &NavState, p: &VerticalParams) -> Option<f64> {
        let above = self.vertical_m(RangefinderOrientation::Up, now, nav, p.timeout_s)??;
        Some(nav.position_ned_m[2] - above + p.margin_m)
    }

    /// The vertical distance to the surface under the vehicle (m), if the downward beam sees one.
    pub fn below_m(&self, now: Time, nav: &NavState, p: &VerticalParams) -> Option<f64> {
        self.vertical_m(RangefinderOrientation::Down, now, nav, p.timeout_s)?
    }

    /// Whether the downward beam has a fresh reading (a surface or nothing in range).
    pub fn down_fresh(&self, now: Time, nav: &NavState, p: &VerticalParams) -> bool {
        self.vertical_m(RangefinderOrientation::Down, now, nav, p.timeout_s).is_some()
    }
}

/// Keeps `sp` from taking a vehicle at `down_m` (NED, m) above `ceiling_down_m`: a position
/// target no higher, a climb no faster than stops in the gap, inside the margin a slow descent
/// back. Whether it changed anything.
pub(super) fn hold_below(
    sp: &mut TrajectorySetpoint,
    down_m: f64,
    ceiling_down_m: f64,
    p: &VerticalParams,
) -> bool {
    let mut changed = false;
    if let Some(target) = &mut sp.position_ned_m[2]
        && *target < ceiling_down_m
    {
        *target = ceiling_down_m;
        changed = true;
    }
    let gap = down_m - ceiling_down_m;
    let stopping = |distance: f64| (2.0 * p.climb_accel_m_s2 * distance.abs()).sqrt();
    let least_down_m_s = if gap >= 0.0 { -stopping(gap) } else { stopping(gap).min(p.backup_speed_m_s) };
    match &mut sp.velocity_ned_m_s[2] {
        Some(v) if *v < least_down_m_s => {
            *v = least_down_m_s;
            changed = true;
        }
        None if gap < 0.0 && sp.position_ned_m[2].is_none() => {
            sp.velocity_ned_m_s[2] = Some(least_down_m_s);
            changed = true;
        }
        _ => {}
    }
    changed
}

/// A landing moving off an obstacle's top.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct LandingSearch {
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
    /// One step of the search at `nav` over the spot `spot_ne` (without the offset), the beam
    /// reading `below_m` (a fresh reading; `None` for nothing in range), home at `home_down_m`,
    /// the vehicle facing `yaw_rad`. Moves the offset and the held height; sets `done`.
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &mut self,
        nav: &NavState,
        spot_ne: [f64; 2],
        below_m: Option<f64>,
        home_down_m: f64,
        yaw_rad: f64,
        p: &VerticalParams,
    ) {
        if self.done || p.obstacle_below_m <= 0.0 {
            self.below_m = None;
            return;
        }
        let [n, e, down] = nav.position_ned_m;
        let surface_height_m = below_m.map(|b| home_down_m - (down + b));
        let on_top = surface_height_m.is_some_and(|h| h > p.obstacle_below_m);
        let target = [spot_ne[0] + self.offset_ne_m[0], spot_ne[1] + self.offset_ne_m[1]];
        let there = (n - target[0]).hypot(e - target[1]) < AT_SPOT_M;
        if on_top {
            self.below_m = below_m;
            let top_down_m = down + below_m.unwrap_or(0.0);
            let hold = (top_down_m - p.margin_m).min(self.hold_down_m.unwrap_or(down));
            self.hold_down_m = Some(hold);
            self.clearing = false;
            if self.direction_ne.is_none() || there {
                let direction = *self.direction_ne.get_or_insert([-yaw_rad.cos(), -yaw_rad.sin()]);
                if self.moved_m + p.land_shift_m > p.land_search_m {
                    tracing::warn!(moved_m = self.moved_m, "landing: no clear ground found, landing here");
                    self.done = true;
                    self.below_m = None;
                    return;
                }
                self.shift(direction, p.land_shift_m);
            }
        } else if let Some(direction) = self.direction_ne {
            // Moving off a top, now over the ground (or over nothing the beam reaches).
            if !self.clearing && there {
                self.clearing = true;
                self.shift(direction, p.land_shift_m);
            } else if self.clearing && there {
                self.done = true;
                self.below_m = None;
            }
        }
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
            time: Time::from_secs_f64(10.0),
            attitude: quaternion_from_euler(roll_rad, 0.0, 0.0),
            angular_velocity_rad_s: [0.0; 3],
            velocity_ned_m_s: [0.0; 3],
            position_ned_m: [0.0, 0.0, down_m],
            gyro_bias_rad_s: [0.0; 3],
            accel_bias_m_s2: [0.0; 3],
            covariance_diagonal: [0.0; 16],
            origin: None,
            valid: kestrel_proto::messages::NavValidity::default(),
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
        // Above the ceiling by 0.5 m: back down at √(2·1·0.5) = 1 m/s, capped at 0.75.
        let mut sp =
            TrajectorySetpoint { velocity_ned_m_s: [None, None, Some(0.0)], ..TrajectorySetpoint::default() };
        assert!(hold_below(&mut sp, -5.5, -5.0, &p));
        assert_eq!(sp.velocity_ned_m_s[2], Some(0.75));
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
        /// and a vertical rate never climbs faster than stops in the gap (and climbs not at all
        /// inside the margin).
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
            if let Some(t) = sp.position_ned_m[2] {
                proptest::prop_assert!(t >= ceiling);
            }
            if let Some(v) = sp.velocity_ned_m_s[2] {
                let gap = down - ceiling;
                if gap >= 0.0 {
                    proptest::prop_assert!(v >= -(2.0 * gap).sqrt() - 1e-12);
                } else {
                    proptest::prop_assert!(v > 0.0);
                }
            }
        }
    }

    #[test]
    fn a_landing_over_a_top_holds_moves_back_past_the_edge_then_lands() {
        let p = VerticalParams::default();
        let mut s = LandingSearch::default();
        // 10 m up facing north, a 4 m top under the vehicle (6 m below it).
        let mut nav = nav_at(-10.0, 0.0);
        s.step(&nav, [0.0, 0.0], Some(6.0), 0.0, 0.0, &p);
        assert!(s.searching());
        assert_eq!(s.hold_down_m, Some(-10.0));
        assert_eq!(s.offset_ne_m, [-2.0, 0.0]);
        // Not there yet: nothing moves.
        s.step(&nav, [0.0, 0.0], Some(6.0), 0.0, 0.0, &p);
        assert_eq!(s.offset_ne_m, [-2.0, 0.0]);
        // There, still over the top: another step.
        nav.position_ned_m = [-2.0, 0.0, -10.0];
        s.step(&nav, [0.0, 0.0], Some(6.0), 0.0, 0.0, &p);
        assert_eq!(s.offset_ne_m, [-4.0, 0.0]);
        // There, over the ground: one step more to clear the edge, then done.
        nav.position_ned_m = [-4.0, 0.0, -10.0];
        s.step(&nav, [0.0, 0.0], Some(10.0), 0.0, 0.0, &p);
        assert_eq!(s.offset_ne_m, [-6.0, 0.0]);
        assert!(s.searching());
        nav.position_ned_m = [-6.0, 0.0, -10.0];
        s.step(&nav, [0.0, 0.0], Some(10.0), 0.0, 0.0, &p);
        assert!(s.done && !s.searching());
    }

    #[test]
    fn the_ground_below_is_no_obstacle_and_a_search_that_finds_no_ground_lands_where_it_is() {
        let p = VerticalParams { land_search_m: 4.0, ..VerticalParams::default() };
        let mut s = LandingSearch::default();
        let mut nav = nav_at(-10.0, 0.0);
        // The ground 10 m below, and a top 1 m high (under obstacle_below_m): no search.
        s.step(&nav, [0.0, 0.0], Some(10.0), 0.0, 0.0, &p);
        s.step(&nav, [0.0, 0.0], Some(9.0), 0.0, 0.0, &p);
        assert!(!s.searching() && s.offset_ne_m == [0.0, 0.0]);
        // Over a wide roof, facing east: back west 2 m, 4 m, then gives up.
        s.step(&nav, [0.0, 0.0], Some(6.0), 0.0, std::f64::consts::FRAC_PI_2, &p);
        assert!((s.offset_ne_m[1] - -2.0).abs() < 1e-12);
        nav.position_ned_m = [0.0, -2.0, -10.0];
        s.step(&nav, [0.0, 0.0], Some(6.0), 0.0, 0.0, &p);
        nav.position_ned_m = [0.0, -4.0, -10.0];
        s.step(&nav, [0.0, 0.0], Some(6.0), 0.0, 0.0, &p);
        assert!(s.done);
    }
}
