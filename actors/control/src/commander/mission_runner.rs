//! Flying a [`Mission`]: which item is current, when it counts as reached, and the
//! trajectory setpoint towards it.
//!
//! The walk through the items is ArduPilot's `AP_Mission`: one navigation item is current
//! (`MissionItem::is_nav`); the do and condition items found on the way to it run in order
//! while it is flown, a condition holding back the do items after it until it is met, and
//! those not run when the navigation item is done are dropped. DO_JUMP only redirects the
//! walk: taken while it has been taken fewer than its repeat count (for ever at -1), counts
//! restarting with each run; a walk that takes more than 64 jumps without finding an item to
//! fly ends the mission, as `AP_Mission::get_next_cmd` does. Held by
//! `tests::jumps_fly_the_items_the_counts_say` (proptest against a plain interpreter).

use kestrel_proto::Time;
use kestrel_proto::geo::{Geodetic, LocalFrame};
use kestrel_proto::messages::{
    AltitudeFrame, CameraAction, Mission, MissionItem, MissionPoint, MissionProgress, TrajectorySetpoint,
};
use nalgebra::Vector3;

use super::spline::SplineLeg;

/// A take-off item counts as reached within this height (m).
const TAKEOFF_TOLERANCE_M: f64 = 0.5;
/// A loiter or spline point counts as reached within this distance (m): ArduCopter's
/// `WPNAV_RADIUS` default.
const LOITER_RADIUS_M: f64 = 2.0;
/// Most jumps one walk takes before it gives up (`AP_Mission::get_next_cmd`'s `max_loops`).
const MAX_JUMPS_PER_WALK: u32 = 64;
/// Most items one walk passes before it gives up (`advance_current_nav_cmd`'s `max_loops`).
const MAX_ITEMS_PER_WALK: u32 = 255;
/// Most navigation items completed in one update: a loop of items that are done as soon as
/// they start (zero delays) goes on at the next update instead of spinning here.
const MAX_COMPLETIONS_PER_UPDATE: u32 = 64;
/// ArduCopter's `CIRCLE_RATE` default (deg/s): the angular rate of a LOITER_TURNS circle,
/// lowered where it would exceed the cruise speed.
const CIRCLE_RATE_DEG_S: f64 = 20.0;
/// A CONDITION_YAW is met within this angle (deg), as ArduCopter's `verify_yaw`.
const YAW_MET_DEG: f64 = 2.0;
/// Nearer than this (m, horizontally) to a region of interest the nose is left alone.
const ROI_MIN_DISTANCE_M: f64 = 1.0;

/// What the mission wants now.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MissionStep {
    /// Fly this setpoint.
    Fly(TrajectorySetpoint),
    /// Land at this NED horizontal position (m).
    Land { north_m: f64, east_m: f64 },
    /// Hand over to RTL.
    ReturnToLaunch,
    /// Every item done: hold where the last one left the vehicle.
    Finished,
}

/// What happened in an update that the commander reports (STATUSTEXT) or acts on. Item
/// indexes are the mission's (the ground station's item number is one more).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MissionEvent {
    /// A camera item ran.
    Camera { index: usize, action: CameraAction },
    /// An item for an output the vehicle does not have ran; nothing was driven.
    NoOutput { index: usize, command: u16 },
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    /// Flying to the current item; the NED target is resolved when the item starts.
    Flying { target: Vector3<f64> },
    /// Reached; waiting until then before the next item.
    Holding { target: Vector3<f64>, until: Time },
    /// Reached; held until the ground station moves the mission on (LOITER_UNLIM).
    Loitering { target: Vector3<f64> },
    /// Circling `center` (a LOITER_TURNS): `angle_rad` is where on the circle the setpoint is
    /// (from north towards east), `left_rad` the angle still to turn (always positive).
    Circling { center: Vector3<f64>, angle_rad: f64, left_rad: f64 },
    /// Along a spline leg, the setpoint at `s`.
    Spline { leg: SplineLeg, s: f64 },
}

/// Where the nose points in AUTO.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Yaw {
    /// Left to the commander (it holds the heading).
    Free,
    /// At this NED point (DO_SET_ROI).
    Roi(Vector3<f64>),
    /// Turning to `target_rad` at `rate_rad_s` (0: at once); `command_rad` is where the
    /// setpoint is now.
    Turn { target_rad: f64, rate_rad_s: f64, command_rad: f64 },
}

/// Progress through one mission.
#[derive(Clone, Debug)]
pub struct MissionRunner {
    mission: Mission,
    cruise_m_s: f64,
    /// The navigation item being flown (== the item count when finished).
    current: usize,
    reached: u32,
    last_reached: Option<usize>,
    phase: Option<Phase>,
    /// The walk to start at this item at the next update (a new run, a jump by the ground
    /// station, a replaced mission, a jump to the landing sequence).
    pending_walk: Option<usize>,
    /// Times each DO_JUMP has been taken in this run (indexed like the items).
    jumps_taken: Vec<i32>,
    /// The do item to run next, if any, and whether its condition has started (when a
    /// condition delay ends, or that a yaw turn was started).
    next_do: Option<usize>,
    condition: Option<Condition>,
    yaw: Yaw,
    /// The spline tangent the last leg ended with, for a spline leg that follows it.
    spline_tangent: Option<Vector3<f64>>,
    /// The last update's time, for the rates (yaw turn, circle, spline).
    last_update: Option<Time>,
    /// Reported to the commander; drained by [`MissionRunner::drain_events`]. Its capacity is
    /// reserved once so that an update does not allocate.
    events: Vec<MissionEvent>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Condition {
    DelayUntil(Time),
    YawStarted,
}

impl MissionRunner {
    pub fn new(mission: Mission) -> MissionRunner {
        MissionRunner {
            cruise_m_s: mission.cruise_speed_m_s,
            jumps_taken: vec![0; mission.items.len()],
            mission,
            current: 0,
            reached: 0,
            last_reached: None,
            phase: None,
            pending_walk: Some(0),
            next_do: None,
            condition: None,
            yaw: Yaw::Free,
            spline_tangent: None,
            last_update: None,
            events: Vec::with_capacity(16),
        }
    }

    /// Flies the legs from now on at `speed_m_s` (m/s), as a DO_CHANGE_SPEED item does.
    pub fn set_cruise(&mut self, speed_m_s: f64) {
        self.cruise_m_s = speed_m_s;
    }

    /// Makes item `index` current: flown next, from wherever the vehicle is (the items between
    /// are skipped, as MAVLink's MISSION_SET_CURRENT asks; a do item made current runs, and the
    /// walk goes on to the next navigation item, as ArduPilot's `set_current_cmd`). `false`, and
    /// nothing changed, when there is no such item.
    pub fn set_current(&mut self, index: usize) -> bool {
        if index >= self.mission.items.len() {
            return false;
        }
        self.current = index;
        self.pending_walk = Some(index);
        self.phase = None;
        true
    }

    /// Flies `mission` instead, from the item index being flown (the new mission's last item
    /// when it is shorter), as ArduCopter restarts its current command from a mission uploaded
    /// in AUTO. The count of items reached goes on (MISSION_ITEM_REACHED is sent for each new
    /// one), and so does the cruise speed in force; the item is started afresh, its target
    /// resolved from the new mission, and the jump counts start again. A run that had finished
    /// stays finished.
    /// Held by `tests::replace_keeps_the_index_within_the_new_mission` and the commander's
    /// `a_mission_uploaded_in_auto_is_flown_from_the_same_item`.
    pub fn replace(&mut self, mission: Mission) {
        let finished = self.current >= self.mission.items.len() && self.pending_walk.is_none();
        let last = mission.items.len().saturating_sub(1);
        self.current = if finished { mission.items.len() } else { self.current.min(last) };
        self.pending_walk = (!finished).then_some(self.current);
        self.jumps_taken = vec![0; mission.items.len()];
        self.mission = mission;
        self.phase = None;
        self.next_do = None;
        self.condition = None;
    }

    /// Goes on at the landing sequence: the DO_LAND_START nearest the vehicle (to its point;
    /// the first when none has one), as ArduCopter's AUTO RTL (`jump_to_landing_sequence`).
    /// `false`, and nothing changed, when the mission has none.
    pub fn jump_to_landing_sequence(
        &mut self,
        pos: &Vector3<f64>,
        frame: &LocalFrame,
        home: &Vector3<f64>,
    ) -> bool {
        let mut best: Option<(usize, f64)> = None;
        for (i, item) in self.mission.items.iter().enumerate() {
            if let MissionItem::LandStart { point } = item {
                let d = point.map_or(f64::INFINITY, |p| {
                    let t = resolve(&p, frame, home, pos);
                    (t.x - pos.x).hypot(t.y - pos.y)
                });
                if best.is_none_or(|(_, b)| d < b) {
                    best = Some((i, d));
                }
            }
        }
        let Some((i, _)) = best else { return false };
        self.set_current(i)
    }

    /// The events of the updates since the last call, oldest first.
    pub fn drain_events(&mut self) -> std::vec::Drain<'_, MissionEvent> {
        self.events.drain(..)
    }

    /// Progress for `VehicleStatus`. A return-to-launch item counts as reached when RTL takes
    /// over; a land item when the vehicle has landed. Completed once the walk finds no more
    /// items to fly.
    pub fn progress(&self) -> MissionProgress {
        let index = |i: usize| u32::try_from(i).unwrap_or(u32::MAX);
        MissionProgress {
            current: index(self.current),
            reached: self.reached,
            last_reached: self.last_reached.map(index),
            total: index(self.mission.items.len()),
            completed: self.pending_walk.is_none() && self.current >= self.mission.items.len(),
        }
    }

    /// The vehicle has landed: a land item being flown is thereby reached.
    pub fn landed(&mut self) {
        if self.pending_walk.is_none()
            && matches!(self.mission.items.get(self.current), Some(MissionItem::Land { .. }))
        {
            self.complete_nav();
        }
    }

    /// The next step, given the vehicle's NED position and heading (rad), the NED frame, home
    /// (NED, m) and the highest the vehicle may climb under something seen overhead for a while
    /// (NED down, m; `None`: no limit).
    /// Under such a ceiling a take-off or a waypoint counts as reached at the ceiling: the
    /// vehicle cannot climb to it, and flying on moves it out from under.
    pub fn update(
        &mut self,
        now: Time,
        pos: &Vector3<f64>,
        heading_rad: f64,
        frame: &LocalFrame,
        home: &Vector3<f64>,
        ceiling_down_m: Option<f64>,
    ) -> MissionStep {
        let dt_s = self.last_update.map_or(0.0, |t| now.saturating_since(t).as_secs_f64());
        self.last_update = Some(now);
        let reachable = |t: Vector3<f64>| match ceiling_down_m {
            Some(c) => Vector3::new(t.x, t.y, t.z.max(c)),
            None => t,
        };
        let mut completions = 0;
        loop {
            if let Some(start) = self.pending_walk.take() {
                self.walk_from(start);
            }
            if completions >= MAX_COMPLETIONS_PER_UPDATE {
                let hold = self.setpoint(pos, pos, heading_rad);
                return MissionStep::Fly(hold);
            }
            self.run_do_items(now, (pos, heading_rad, dt_s), frame, home);
            let Some(item) = self.mission.items.get(self.current).copied() else {
                return MissionStep::Finished;
            };
            let step = match item {
                MissionItem::ReturnToLaunch => {
                    self.complete_nav();
                    return MissionStep::ReturnToLaunch;
                }
                MissionItem::Land { point } => {
                    let target = resolve(&point, frame, home, pos);
                    return MissionStep::Land { north_m: target.x, east_m: target.y };
                }
                MissionItem::Takeoff { point } => {
                    let target = self.target_or(|| {
                        let t = resolve(&point, frame, home, pos);
                        Vector3::new(pos.x, pos.y, t.z)
                    });
                    if (pos.z - reachable(target).z).abs() < TAKEOFF_TOLERANCE_M {
                        None
                    } else {
                        Some(MissionStep::Fly(self.setpoint(&target, pos, heading_rad)))
                    }
                }
                MissionItem::Waypoint { point, acceptance_radius_m, hold_s } => {
                    let target = self.target_or(|| resolve(&point, frame, home, pos));
                    self.arrive(now, pos, heading_rad, target, reachable(target), acceptance_radius_m, hold_s)
                }
                MissionItem::SplineWaypoint { point, hold_s } => {
                    self.spline(now, dt_s, pos, heading_rad, frame, home, &point, hold_s, &reachable)
                }
                MissionItem::LoiterTime { duration_s, point } => {
                    let target = self.target_or(|| point.map_or(*pos, |p| resolve(&p, frame, home, pos)));
                    self.arrive(now, pos, heading_rad, target, reachable(target), LOITER_RADIUS_M, duration_s)
                }
                MissionItem::Delay { duration_s } => {
                    let target = self.target_or(|| *pos);
                    self.arrive(now, pos, heading_rad, target, target, f64::INFINITY, duration_s)
                }
                MissionItem::LoiterUnlimited { point } => {
                    let target = self.target_or(|| point.map_or(*pos, |p| resolve(&p, frame, home, pos)));
                    if matches!(self.phase, Some(Phase::Flying { .. }))
                        && (pos - reachable(target)).norm() <= LOITER_RADIUS_M
                    {
                        self.phase = Some(Phase::Loitering { target });
                    }
                    Some(MissionStep::Fly(self.setpoint(&target, pos, heading_rad)))
                }
                MissionItem::LoiterTurns { point, turns, radius_m } => {
                    let center = point.map_or(*pos, |p| resolve(&p, frame, home, pos));
                    self.circle(dt_s, pos, heading_rad, center, turns, radius_m, &reachable)
                }
                // The walk never stops at a do item or a jump.
                _ => None,
            };
            match step {
                Some(step) => return step,
                None => {
                    completions += 1;
                    self.complete_nav();
                }
            }
        }
    }

    /// The current navigation item is done: counted, and the walk goes on after it.
    fn complete_nav(&mut self) {
        self.last_reached = Some(self.current);
        self.reached += 1;
        self.walk_from(self.current + 1);
    }

    /// Finds the next navigation item from `start`, following jumps (and counting them), and
    /// the first do item passed on the way (run while it is flown). None found: finished.
    fn walk_from(&mut self, start: usize) {
        let n = self.mission.items.len();
        self.phase = None;
        self.next_do = None;
        self.condition = None;
        if !matches!(self.yaw, Yaw::Roi(_)) {
            self.yaw = Yaw::Free;
        }
        let mut index = start;
        for _ in 0..MAX_ITEMS_PER_WALK {
            let Some(i) = self.next_item(index, true) else { break };
            if self.mission.items[i].is_nav() {
                self.current = i;
                return;
            }
            self.next_do.get_or_insert(i);
            index = i + 1;
        }
        self.next_do = None;
        self.current = n;
    }

    /// The first item at or after `start` that is not a jump, the jumps followed as their
    /// counts say (counted when `count`: the walk to the next navigation item counts, the walk
    /// through the do items does not). `None` past the end or after too many jumps.
    fn next_item(&mut self, start: usize, count: bool) -> Option<usize> {
        let mut i = start;
        let mut jumps = 0;
        while let Some(item) = self.mission.items.get(i) {
            let MissionItem::Jump { target, repeat } = *item else { return Some(i) };
            jumps += 1;
            if jumps > MAX_JUMPS_PER_WALK {
                return None;
            }
            if repeat == -1 {
                i = target as usize;
            } else if self.jumps_taken[i] < repeat {
                if count {
                    self.jumps_taken[i] += 1;
                }
                i = target as usize;
            } else {
                i += 1;
            }
        }
        None
    }

    /// Runs the do items due, in order, until one waits (a condition not met yet) or the
    /// next is a navigation item.
    fn run_do_items(
        &mut self,
        now: Time,
        (pos, heading_rad, dt_s): (&Vector3<f64>, f64, f64),
        frame: &LocalFrame,
        home: &Vector3<f64>,
    ) {
        for _ in 0..MAX_ITEMS_PER_WALK {
            let Some(i) = self.next_do else { return };
            let item = self.mission.items[i];
            match item {
                MissionItem::ConditionDelay { duration_s } => {
                    let until = match self.condition {
                        Some(Condition::DelayUntil(t)) => t,
                        _ => {
                            let t = now + std::time::Duration::from_secs_f64(duration_s.clamp(0.0, 86_400.0));
                            self.condition = Some(Condition::DelayUntil(t));
                            t
                        }
                    };
                    if now < until {
                        return;
                    }
                }
                MissionItem::ConditionDistance { distance_m } => match self.nav_target() {
                    Some(t) if (t - pos).norm() <= distance_m => {}
                    _ => return,
                },
                MissionItem::ConditionYaw { angle_deg, rate_deg_s, clockwise, relative } => {
                    if self.condition != Some(Condition::YawStarted) {
                        let target_rad = if relative {
                            heading_rad + angle_deg.to_radians() * if clockwise { 1.0 } else { -1.0 }
                        } else {
                            angle_deg.to_radians()
                        };
                        self.yaw = Yaw::Turn {
                            target_rad,
                            rate_rad_s: rate_deg_s.to_radians(),
                            command_rad: heading_rad,
                        };
                        self.condition = Some(Condition::YawStarted);
                    }
                    let Yaw::Turn { target_rad, .. } = self.yaw else { return };
                    if wrap_pi(heading_rad - target_rad).abs() > YAW_MET_DEG.to_radians() {
                        self.turn_yaw(dt_s);
                        return;
                    }
                }
                MissionItem::ChangeSpeed { speed_m_s } => self.cruise_m_s = speed_m_s,
                MissionItem::RegionOfInterest { point } => {
                    self.yaw = match point {
                        Some(p) => Yaw::Roi(resolve(&p, frame, home, pos)),
                        None => Yaw::Free,
                    };
                }
                MissionItem::Camera { action } => self.events.push(MissionEvent::Camera { index: i, action }),
                MissionItem::NoOutput { command } => {
                    self.events.push(MissionEvent::NoOutput { index: i, command })
                }
                _ => {}
            }
            self.condition = None;
            self.next_do = match self.next_item(i + 1, false) {
                Some(j) if !self.mission.items[j].is_nav() => Some(j),
                _ => None,
            };
        }
    }

    fn nav_target(&self) -> Option<Vector3<f64>> {
        match self.phase? {
            Phase::Flying { target } | Phase::Holding { target, .. } | Phase::Loitering { target } => {
                Some(target)
            }
            Phase::Circling { center, .. } => Some(center),
            Phase::Spline { leg, .. } => Some(leg.end()),
        }
    }

    fn turn_yaw(&mut self, dt_s: f64) {
        if let Yaw::Turn { target_rad, rate_rad_s, command_rad } = &mut self.yaw {
            let error = wrap_pi(*target_rad - *command_rad);
            let step = if *rate_rad_s > 0.0 { *rate_rad_s * dt_s } else { f64::INFINITY };
            *command_rad += error.clamp(-step, step);
        }
    }

    /// While at `target` (counted as reached at `reachable`, where a ceiling holds the vehicle
    /// below it): the hold setpoint; once the hold is over, `None` (item done).
    #[allow(clippy::too_many_arguments, reason = "the vehicle's state and the item's three numbers")]
    fn arrive(
        &mut self,
        now: Time,
        pos: &Vector3<f64>,
        heading_rad: f64,
        target: Vector3<f64>,
        reachable: Vector3<f64>,
        radius: f64,
        hold_s: f64,
    ) -> Option<MissionStep> {
        match self.phase {
            Some(Phase::Flying { .. }) if (pos - reachable).norm() <= radius => {
                let until = now + std::time::Duration::from_secs_f64(hold_s.clamp(0.0, 86_400.0));
                self.phase = Some(Phase::Holding { target, until });
                self.arrive(now, pos, heading_rad, target, reachable, radius, hold_s)
            }
            Some(Phase::Holding { until, .. }) if now >= until => None,
            _ => Some(MissionStep::Fly(self.setpoint(&target, pos, heading_rad))),
        }
    }

    /// A spline leg: the setpoint moves along the curve at the cruise speed, never more than
    /// a cruise second ahead of the vehicle; reached at the waypoint, then held `hold_s`.
    #[allow(clippy::too_many_arguments, reason = "the vehicle's state and the item")]
    fn spline(
        &mut self,
        now: Time,
        dt_s: f64,
        pos: &Vector3<f64>,
        heading_rad: f64,
        frame: &LocalFrame,
        home: &Vector3<f64>,
        point: &MissionPoint,
        hold_s: f64,
        reachable: &dyn Fn(Vector3<f64>) -> Vector3<f64>,
    ) -> Option<MissionStep> {
        let (leg, s) = match self.phase {
            Some(Phase::Spline { leg, s }) => (leg, s),
            Some(Phase::Holding { target, until }) => {
                return if now >= until {
                    None
                } else {
                    Some(MissionStep::Fly(self.setpoint(&target, pos, heading_rad)))
                };
            }
            _ => {
                let end = resolve(point, frame, home, pos);
                let next = self.next_point_after(self.current).map(|p| resolve(&p, frame, home, pos));
                let leg = SplineLeg::new(*pos, end, self.spline_tangent.take(), next);
                (leg, 0.0)
            }
        };
        let lead_m = (leg.position(s) - pos).norm();
        let s = if lead_m < self.cruise_m_s.max(1.0) { leg.advance(s, self.cruise_m_s * dt_s) } else { s };
        let end = leg.end();
        if s >= 1.0 && (pos - reachable(end)).norm() <= LOITER_RADIUS_M {
            self.spline_tangent = Some(leg.end_tangent());
            let until = now + std::time::Duration::from_secs_f64(hold_s.clamp(0.0, 86_400.0));
            if hold_s <= 0.0 {
                return None;
            }
            self.phase = Some(Phase::Holding { target: end, until });
            return Some(MissionStep::Fly(self.setpoint(&end, pos, heading_rad)));
        }
        self.phase = Some(Phase::Spline { leg, s });
        let mut sp = self.setpoint(&leg.position(s), pos, heading_rad);
        let tangent = leg.tangent(s);
        if s < 1.0 && tangent.norm() > 1e-6 {
            let v = tangent.normalize() * self.cruise_m_s;
            sp.velocity_ned_m_s = [Some(v.x), Some(v.y), Some(v.z)];
        }
        Some(MissionStep::Fly(sp))
    }

    /// The point of the next navigation item after `index` when the vehicle flies on through it
    /// (a waypoint or spline waypoint), for a spline's end tangent; jumps are not followed.
    fn next_point_after(&self, index: usize) -> Option<MissionPoint> {
        let next = self.mission.items.iter().skip(index + 1).find(|i| i.is_nav())?;
        match *next {
            MissionItem::Waypoint { point, hold_s, .. } | MissionItem::SplineWaypoint { point, hold_s }
                if hold_s <= 0.0 =>
            {
                Some(point)
            }
            _ => None,
        }
    }

    /// LOITER_TURNS: fly to the nearest point of the circle, then circle `turns` times, the
    /// nose at the centre (ArduCopter's circle), at `CIRCLE_RATE_DEG_S` or slower where the
    /// cruise speed asks.
    #[allow(clippy::too_many_arguments, reason = "the vehicle's state and the item")]
    fn circle(
        &mut self,
        dt_s: f64,
        pos: &Vector3<f64>,
        heading_rad: f64,
        center: Vector3<f64>,
        turns: f64,
        radius_m: f64,
        reachable: &dyn Fn(Vector3<f64>) -> Vector3<f64>,
    ) -> Option<MissionStep> {
        let r = radius_m.abs();
        let sense = if radius_m < 0.0 { -1.0 } else { 1.0 };
        let on_circle = |angle: f64| center + Vector3::new(r * angle.cos(), r * angle.sin(), 0.0);
        match self.phase {
            None => {
                let (dn, de) = (pos.x - center.x, pos.y - center.y);
                let angle = if dn.hypot(de) > 0.1 { de.atan2(dn) } else { 0.0 };
                self.phase = Some(Phase::Flying { target: on_circle(angle) });
                self.circle(dt_s, pos, heading_rad, center, turns, radius_m, reachable)
            }
            Some(Phase::Flying { target }) => {
                if (pos - reachable(target)).norm() <= LOITER_RADIUS_M {
                    let angle = (target.y - center.y).atan2(target.x - center.x);
                    let left_rad = turns * std::f64::consts::TAU;
                    self.phase = Some(Phase::Circling { center, angle_rad: angle, left_rad });
                }
                Some(MissionStep::Fly(self.setpoint(&target, pos, heading_rad)))
            }
            Some(Phase::Circling { center, angle_rad, left_rad }) => {
                if left_rad <= 0.0 {
                    return None;
                }
                let rate = CIRCLE_RATE_DEG_S.to_radians().min(if r > 0.0 {
                    self.cruise_m_s / r
                } else {
                    f64::INFINITY
                });
                let turn = (rate * dt_s).min(left_rad);
                let angle_rad = angle_rad + sense * turn;
                self.phase = Some(Phase::Circling { center, angle_rad, left_rad: left_rad - turn });
                let target = on_circle(angle_rad);
                let mut sp = self.setpoint(&target, pos, heading_rad);
                let speed = rate * r * sense;
                sp.velocity_ned_m_s = [Some(-speed * angle_rad.sin()), Some(speed * angle_rad.cos()), None];
                if matches!(self.yaw, Yaw::Free) {
                    // Nose at the centre; turning in place when the radius is 0.
                    sp.yaw_rad = Some(if r > 0.0 {
                        wrap_pi(angle_rad + std::f64::consts::PI)
                    } else {
                        wrap_pi(angle_rad)
                    });
                }
                Some(MissionStep::Fly(sp))
            }
            Some(_) => None,
        }
    }

    fn target_or(&mut self, resolve: impl FnOnce() -> Vector3<f64>) -> Vector3<f64> {
        match self.phase {
            Some(Phase::Flying { target } | Phase::Holding { target, .. } | Phase::Loitering { target }) => {
                target
            }
            _ => {
                let target = resolve();
                self.phase = Some(Phase::Flying { target });
                target
            }
        }
    }

    /// The position setpoint at `target`, at the cruise speed, the nose where the mission
    /// points it (`None`: the commander holds it).
    fn setpoint(&self, target: &Vector3<f64>, pos: &Vector3<f64>, heading_rad: f64) -> TrajectorySetpoint {
        let yaw_rad = match self.yaw {
            Yaw::Free => None,
            Yaw::Roi(roi) => {
                let (dn, de) = (roi.x - pos.x, roi.y - pos.y);
                Some(if dn.hypot(de) > ROI_MIN_DISTANCE_M { de.atan2(dn) } else { heading_rad })
            }
            Yaw::Turn { command_rad, .. } => Some(wrap_pi(command_rad)),
        };
        TrajectorySetpoint {
            position_ned_m: [Some(target.x), Some(target.y), Some(target.z)],
            max_horizontal_speed_m_s: Some(self.cruise_m_s),
            yaw_rad,
            ..TrajectorySetpoint::default()
        }
    }
}

/// An angle wrapped to -π..π (rad).
fn wrap_pi(a: f64) -> f64 {
    let a = a.rem_euclid(std::f64::consts::TAU);
    if a > std::f64::consts::PI { a - std::f64::consts::TAU } else { a }
}

/// NED position (m) of a mission point; a point without lat/lon keeps the vehicle's north/east.
pub fn resolve(
    point: &MissionPoint,
    frame: &LocalFrame,
    home: &Vector3<f64>,
    pos: &Vector3<f64>,
) -> Vector3<f64> {
    let down = match point.frame {
        AltitudeFrame::RelativeHome => home.z - point.alt_m,
        AltitudeFrame::Amsl => -(point.alt_m - frame.home().alt_m),
    };
    if point.lat_deg.is_finite() && point.lon_deg.is_finite() {
        let ned = frame.to_ned(Geodetic {
            lat_deg: point.lat_deg,
            lon_deg: point.lon_deg,
            alt_m: frame.home().alt_m,
        });
        Vector3::new(ned[0], ned[1], down)
    } else {
        Vector3::new(pos.x, pos.y, down)
    }
}

#[cfg(test)]
#[path = "mission_runner_tests.rs"]
mod tests;
