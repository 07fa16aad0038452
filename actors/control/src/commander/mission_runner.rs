//! Flying a [`Mission`]: which item is current, when it counts as reached, and the
//! trajectory setpoint towards it.

use kestrel_proto::Time;
use kestrel_proto::geo::{Geodetic, LocalFrame};
use kestrel_proto::messages::{
    AltitudeFrame, Mission, MissionItem, MissionPoint, MissionProgress, TrajectorySetpoint,
};
use nalgebra::Vector3;

/// A take-off item counts as reached within this height (m).
const TAKEOFF_TOLERANCE_M: f64 = 0.5;

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

#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    /// Flying to the current item; the NED target is resolved when the item starts.
    Flying { target: Vector3<f64> },
    /// Reached; waiting until then before the next item.
    Holding { target: Vector3<f64>, until: Time },
}

/// Progress through one mission.
#[derive(Clone, Debug)]
pub struct MissionRunner {
    mission: Mission,
    cruise_m_s: f64,
    current: usize,
    reached: u32,
    last_reached: Option<usize>,
    phase: Option<Phase>,
}

impl MissionRunner {
    pub fn new(mission: Mission) -> MissionRunner {
        MissionRunner {
            cruise_m_s: mission.cruise_speed_m_s,
            mission,
            current: 0,
            reached: 0,
            last_reached: None,
            phase: None,
        }
    }

    /// Flies the legs from now on at `speed_m_s` (m/s), as a DO_CHANGE_SPEED item does.
    pub fn set_cruise(&mut self, speed_m_s: f64) {
        self.cruise_m_s = speed_m_s;
    }

    /// Makes item `index` current: flown next, from wherever the vehicle is (the items between
    /// are skipped, as MAVLink's MISSION_SET_CURRENT asks). `false`, and nothing changed, when
    /// there is no such item.
    pub fn set_current(&mut self, index: usize) -> bool {
        if index >= self.mission.items.len() {
            return false;
        }
        self.current = index;
        self.phase = None;
        true
    }

    /// Flies `mission` instead, from the item index being flown (the new mission's last item
    /// when it is shorter), as ArduCopter restarts its current command from a mission uploaded
    /// in AUTO. The count of items reached goes on (MISSION_ITEM_REACHED is sent for each new
    /// one), and so does the cruise speed in force; the item is started afresh, its target
    /// resolved from the new mission. A run that had finished stays finished.
    /// Held by `tests::replace_keeps_the_index_within_the_new_mission` and the commander's
    /// `a_mission_uploaded_in_auto_is_flown_from_the_same_item`.
    pub fn replace(&mut self, mission: Mission) {
        let finished = self.current >= self.mission.items.len();
        let last = mission.items.len().saturating_sub(1);
        self.current = if finished { mission.items.len() } else { self.current.min(last) };
        self.mission = mission;
        self.phase = None;
    }

    /// Progress for `VehicleStatus`. A return-to-launch item counts as reached when RTL takes
    /// over; a land item when the vehicle has landed. Completed once the last item is done,
    /// whether or not a jump skipped some before it.
    pub fn progress(&self) -> MissionProgress {
        let index = |i: usize| u32::try_from(i).unwrap_or(u32::MAX);
        MissionProgress {
            current: index(self.current),
            reached: self.reached,
            last_reached: self.last_reached.map(index),
            total: index(self.mission.items.len()),
            completed: self.current >= self.mission.items.len(),
        }
    }

    /// The vehicle has landed: a land item being flown is thereby reached.
    pub fn landed(&mut self) {
        if matches!(self.mission.items.get(self.current), Some(MissionItem::Land { .. })) {
            self.advance();
        }
    }

    /// The next step, given the vehicle's NED position, the NED frame, home (NED, m) and the
    /// highest the vehicle may climb under something seen overhead for a while (NED down, m;
    /// `None`: no limit).
    /// Under such a ceiling a take-off or a waypoint counts as reached at the ceiling: the
    /// vehicle cannot climb to it, and flying on moves it out from under.
    pub fn update(
        &mut self,
        now: Time,
        pos: &Vector3<f64>,
        frame: &LocalFrame,
        home: &Vector3<f64>,
        ceiling_down_m: Option<f64>,
    ) -> MissionStep {
        let reachable = |t: Vector3<f64>| match ceiling_down_m {
            Some(c) => Vector3::new(t.x, t.y, t.z.max(c)),
            None => t,
        };
        loop {
            let Some(item) = self.mission.items.get(self.current).copied() else {
                return MissionStep::Finished;
            };
            match item {
                MissionItem::ChangeSpeed { speed_m_s } => {
                    self.cruise_m_s = speed_m_s;
                    self.advance();
                }
                MissionItem::ReturnToLaunch => {
                    self.advance();
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
                        self.advance();
                        continue;
                    }
                    return MissionStep::Fly(self.setpoint(&target));
                }
                MissionItem::Waypoint { point, acceptance_radius_m, hold_s } => {
                    let target = self.target_or(|| resolve(&point, frame, home, pos));
                    if let Some(step) =
                        self.arrive(now, pos, target, reachable(target), acceptance_radius_m, hold_s)
                    {
                        return step;
                    }
                }
                MissionItem::LoiterTime { duration_s } => {
                    let target = self.target_or(|| *pos);
                    if let Some(step) = self.arrive(now, pos, target, target, f64::INFINITY, duration_s) {
                        return step;
                    }
                }
            }
        }
    }

    /// While at `target` (counted as reached at `reachable`, where a ceiling holds the vehicle
    /// below it): the hold setpoint; once the hold is over, `None` (item done).
    fn arrive(
        &mut self,
        now: Time,
        pos: &Vector3<f64>,
        target: Vector3<f64>,
        reachable: Vector3<f64>,
        radius: f64,
        hold_s: f64,
    ) -> Option<MissionStep> {
        match self.phase {
            Some(Phase::Flying { .. }) if (pos - reachable).norm() <= radius => {
                let until = now + std::time::Duration::from_secs_f64(hold_s.clamp(0.0, 86_400.0));
                self.phase = Some(Phase::Holding { target, until });
                self.arrive(now, pos, target, reachable, radius, hold_s)
            }
            Some(Phase::Holding { until, .. }) if now >= until => {
                self.advance();
                None
            }
            _ => Some(MissionStep::Fly(self.setpoint(&target))),
        }
    }

    fn target_or(&mut self, resolve: impl FnOnce() -> Vector3<f64>) -> Vector3<f64> {
        match self.phase {
            Some(Phase::Flying { target } | Phase::Holding { target, .. }) => target,
            None => {
                let target = resolve();
                self.phase = Some(Phase::Flying { target });
                target
            }
        }
    }

    fn advance(&mut self) {
        self.last_reached = Some(self.current);
        self.current += 1;
        self.reached += 1;
        self.phase = None;
    }

    fn setpoint(&self, target: &Vector3<f64>) -> TrajectorySetpoint {
        TrajectorySetpoint {
            position_ned_m: [Some(target.x), Some(target.y), Some(target.z)],
            max_horizontal_speed_m_s: Some(self.cruise_m_s),
            ..TrajectorySetpoint::default()
        }
    }
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
mod tests {
    use kestrel_proto::Time;
    use kestrel_proto::messages::{Mission, MissionItem};

    use super::MissionRunner;

    fn loiters(n: usize) -> Mission {
        Mission {
            time: Time::ZERO,
            items: vec![MissionItem::LoiterTime { duration_s: 1.0 }; n],
            cruise_speed_m_s: 5.0,
        }
    }

    proptest::proptest! {
        /// Whatever the lengths, the item flown after a replacement is the same index or the new
        /// mission's last, the count of reached items goes on, and a finished run stays finished.
        #[test]
        fn replace_keeps_the_index_within_the_new_mission(
            old_len in 1usize..20,
            index in 0usize..25,
            new_len in 1usize..20,
            reached in 0u32..10,
        ) {
            let mut runner = MissionRunner::new(loiters(old_len));
            let index = index.min(old_len);
            runner.current = index;
            runner.reached = reached;
            runner.replace(loiters(new_len));
            let p = runner.progress();
            let finished = index >= old_len;
            let want = if finished { new_len } else { index.min(new_len - 1) };
            proptest::prop_assert_eq!(p.current as usize, want);
            proptest::prop_assert_eq!(p.completed, finished);
            proptest::prop_assert_eq!(p.total as usize, new_len);
            proptest::prop_assert_eq!(p.reached, reached);
        }
    }
}
