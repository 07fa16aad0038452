//! The estimator's recent poses, so that a depth grid is placed in the world with the pose at
//! its capture time rather than at its arrival (tens of milliseconds of stereo processing
//! later: 10 cm at 3 m/s, and more in heading while the vehicle turns).

use kestrel_proto::Time;

use crate::avoidance::memory::Pose;

/// Poses kept: with [`SPACING_US`] between them, 1.28 s of history, far more than a grid's
/// latency.
const SLOTS: usize = 64;
/// Poses nearer in time than this to the newest kept one (µs) only replace it: the estimator
/// publishes at 400 Hz, and 20 ms of motion is 6 cm at 3 m/s.
const SPACING_US: u64 = 20_000;

/// A ring of recent poses, oldest overwritten first; no allocation after construction.
#[derive(Debug, Clone)]
pub struct PoseHistory {
    slots: [Option<Pose>; SLOTS],
    /// Index of the newest pose.
    newest: usize,
}

impl Default for PoseHistory {
    fn default() -> PoseHistory {
        PoseHistory { slots: [None; SLOTS], newest: 0 }
    }
}

impl PoseHistory {
    /// Records `pose`; one older than the newest is ignored. The newest slot always holds
    /// the newest pose; a new slot is started once the newest is [`SPACING_US`] after the one
    /// before it.
    pub fn push(&mut self, pose: Pose) {
        let Some(newest) = self.slots[self.newest] else {
            self.slots[self.newest] = Some(pose);
            return;
        };
        if pose.time < newest.time {
            return;
        }
        let previous = self.slots[(self.newest + SLOTS - 1) % SLOTS];
        if previous.is_none_or(|p| newest.time.0 >= p.time.0 + SPACING_US) {
            self.newest = (self.newest + 1) % SLOTS;
        }
        self.slots[self.newest] = Some(pose);
    }

    /// The newest pose.
    pub fn newest(&self) -> Option<Pose> {
        self.slots[self.newest]
    }

    /// The newest pose not after `time`, or the oldest kept if every pose is after it.
    pub fn at(&self, time: Time) -> Option<Pose> {
        let mut oldest = None;
        for age in 0..SLOTS {
            let Some(pose) = self.slots[(self.newest + SLOTS - age) % SLOTS] else { break };
            if pose.time <= time {
                return Some(pose);
            }
            oldest = Some(pose);
        }
        oldest
    }

    /// Forgets every pose.
    pub fn clear(&mut self) {
        *self = PoseHistory::default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(ms: u64) -> Pose {
        Pose { time: Time(ms * 1000), ned_m: [ms as f64, 0.0, 0.0], yaw_rad: 0.0 }
    }

    #[test]
    fn finds_the_newest_pose_not_after_a_capture_time_at_20_ms_spacing() {
        let mut history = PoseHistory::default();
        assert_eq!(history.at(Time(0)), None);
        // 400 Hz for one second.
        for k in 0..=400 {
            history.push(Pose { time: Time(k * 2500), ned_m: [k as f64, 0.0, 0.0], yaw_rad: 0.0 });
        }
        assert_eq!(history.newest().map(|p| p.time), Some(Time(1_000_000)));
        let at = history.at(Time(965_000)).expect("kept");
        assert!(at.time <= Time(965_000) && at.time >= Time(945_000), "{:?}", at.time);
        // Before the first pose (the ring has not wrapped in one second): the oldest.
        assert_eq!(history.at(Time(0)).map(|p| p.time), Some(Time(0)));
    }

    #[test]
    fn keeps_about_a_second_and_a_quarter_and_ignores_poses_out_of_order() {
        let mut history = PoseHistory::default();
        for ms in (0..=3000).step_by(5) {
            history.push(pose(ms));
        }
        history.push(pose(1000));
        assert_eq!(history.newest(), Some(pose(3000)));
        let oldest = history.at(Time(0)).expect("kept").time;
        assert!(oldest >= Time(1_700_000) && oldest <= Time(1_760_000), "{oldest:?}");
        history.clear();
        assert_eq!(history.newest(), None);
    }
}
