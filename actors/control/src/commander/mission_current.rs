//! MISSION_SET_CURRENT / MAV_CMD_DO_SET_MISSION_CURRENT: which mission item flies next.
//!
//! In AUTO the running mission jumps there at once, from wherever the vehicle is. Otherwise
//! the mode is left alone (the message must not start a mission) and the next run of the
//! mission, by AUTO or MISSION_START, starts there, as ArduPilot resumes at its current item.

use kestrel_proto::messages::FlightMode;

use super::arming::{Refusal, refuse};
use super::{Commander, MissionRunner};

impl Commander {
    /// Makes item `index` (the commander's numbering: the ground station's home is not an
    /// item) current.
    pub(super) fn set_mission_current(&mut self, index: u32) -> Result<(), Refusal> {
        let Some(total) = self.mission.as_ref().map(|m| m.items.len()) else {
            return refuse("set mission item refused: no mission");
        };
        let Some(i) = usize::try_from(index).ok().filter(|&i| i < total) else {
            return refuse(format!("set mission item refused: {index} is past the last ({total} items)"));
        };
        if self.armed
            && self.mode == FlightMode::Auto
            && let Some(runner) = &mut self.runner
        {
            runner.set_current(i);
            // Drop what AUTO latched for the old item (a landing under way, a held position).
            self.enter(FlightMode::Auto);
        } else {
            self.mission_start = Some(i);
            self.runner = None;
            if let Some(runner) = self.new_runner() {
                self.last_progress = runner.progress();
            }
        }
        tracing::info!(index, "mission item made current");
        Ok(())
    }

    /// A fresh run of the uploaded mission, from the item a ground station made current if any.
    pub(super) fn new_runner(&self) -> Option<MissionRunner> {
        let mut runner = MissionRunner::new(self.mission.clone()?);
        if let Some(i) = self.mission_start {
            runner.set_current(i);
        }
        Some(runner)
    }
}
