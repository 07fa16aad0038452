//! The uploaded mission and its run: which mission is held, the run AUTO flies, the item the
//! next run starts from, the progress reported between runs, and a pause.
//!
//! MISSION_SET_CURRENT / MAV_CMD_DO_SET_MISSION_CURRENT: in AUTO the running mission jumps to
//! the item at once, from wherever the vehicle is. Otherwise the mode is left alone (the
//! message must not start a mission) and the next run, by AUTO or MISSION_START, starts there,
//! as ArduPilot resumes at its current item.

use kestrel_proto::Time;
use kestrel_proto::messages::{CameraAction, FlightMode, Mission, MissionProgress};

use super::arming::{Refusal, refuse};
use super::mission_runner::MissionEvent;
use super::{Commander, MissionRunner};

/// The mission held and its run.
#[derive(Debug, Default)]
pub(crate) struct MissionState {
    /// The mission a ground station uploaded, if any.
    pub uploaded: Option<Mission>,
    /// The run AUTO flies; `None` outside one.
    pub runner: Option<MissionRunner>,
    /// The item a ground station made current while no mission was being flown: the next run
    /// starts there (cleared once it does, or by a new mission).
    pub start: Option<usize>,
    /// The progress reported while no run is under way (the last run's, or the new mission's).
    pub last_progress: MissionProgress,
    /// AUTO is paused (DO_PAUSE_CONTINUE): hold where the vehicle stopped, the mission's place
    /// kept. Cleared by a mode change.
    pub paused: bool,
}

impl MissionState {
    /// A fresh run of the uploaded mission, from the item a ground station made current if any.
    pub fn new_runner(&self) -> Option<MissionRunner> {
        let mut runner = MissionRunner::new(self.uploaded.clone()?);
        if let Some(i) = self.start {
            runner.set_current(i);
        }
        Some(runner)
    }

    /// Starts a fresh run (none without a mission).
    pub fn start_run(&mut self) {
        self.runner = self.new_runner();
    }

    /// No mission: the ground station cleared it.
    pub fn clear(&mut self) {
        *self = MissionState { paused: self.paused, ..MissionState::default() };
    }

    /// Holds `mission` in place of the old one. A run under way when `flying` goes on from the
    /// same item (`MissionRunner::replace`, true returned); otherwise there is no run and the
    /// progress is the new mission's.
    pub fn upload(&mut self, mission: Mission, flying: bool) -> bool {
        self.uploaded = Some(mission.clone());
        self.start = None;
        if flying && let Some(runner) = &mut self.runner {
            runner.replace(mission);
            tracing::info!(index = runner.progress().current, "mission replaced in flight");
            true
        } else {
            self.last_progress = MissionRunner::new(mission).progress();
            self.runner = None;
            false
        }
    }

    /// The next run starts from item `i`; the progress says so now.
    pub fn start_next_run_at(&mut self, i: usize) {
        self.start = Some(i);
        self.runner = None;
        if let Some(runner) = self.new_runner() {
            self.last_progress = runner.progress();
        }
    }

    /// The run's progress is kept for the status once it ends.
    pub fn keep_progress(&mut self) {
        if let Some(runner) = &self.runner {
            self.last_progress = runner.progress();
        }
    }

    /// The progress to report: the run's, or the one kept.
    pub fn progress(&self) -> MissionProgress {
        self.runner.as_ref().map_or(self.last_progress, MissionRunner::progress)
    }
}

/// The STATUSTEXT for what a do item did (the item numbered as the ground station numbers it,
/// home being 0, as ArduCopter's "Mission: N ..." texts).
fn event_text(event: &MissionEvent) -> String {
    match *event {
        MissionEvent::NoOutput { index, command } => {
            let name = match command {
                181 => "relay",
                182 => "repeat relay",
                183 => "servo",
                184 => "repeat servo",
                205 => "mount control",
                1000 => "gimbal pitch/yaw",
                _ => "output",
            };
            format!("Mission: {} {name}: no such output", index + 1)
        }
        MissionEvent::Camera { index, action } => {
            let what = match action {
                CameraAction::TriggerDistance { .. } => "trigger distance",
                CameraAction::StartCapture { .. } => "start capture",
                CameraAction::StopCapture => "stop capture",
                CameraAction::Shoot => "shoot",
            };
            format!("Mission: {} camera {what}: no camera output", index + 1)
        }
    }
}

impl Commander {
    /// Reports what the do items run since the last call did that no other message shows: an
    /// item for an output the vehicle lacks is said so (STATUSTEXT), never pretended.
    pub(super) fn report_mission_events(&mut self) {
        let Some(runner) = &mut self.mission.runner else { return };
        let mut newest = None;
        for event in runner.drain_events() {
            let text = event_text(&event);
            tracing::info!(?event, "{text}");
            newest = Some(text);
        }
        if let Some(text) = newest {
            self.announce(text);
        }
    }

    /// Makes item `index` (the commander's numbering: the ground station's home is not an
    /// item) current.
    pub(super) fn set_mission_current(&mut self, index: u32) -> Result<(), Refusal> {
        let Some(total) = self.mission.uploaded.as_ref().map(|m| m.items.len()) else {
            return refuse("set mission item refused: no mission");
        };
        let Some(i) = usize::try_from(index).ok().filter(|&i| i < total) else {
            return refuse(format!("set mission item refused: {index} is past the last ({total} items)"));
        };
        if self.armed
            && self.mode == FlightMode::Auto
            && let Some(runner) = &mut self.mission.runner
        {
            runner.set_current(i);
            // Drop what AUTO latched for the old item (a landing under way, a held position).
            self.enter(FlightMode::Auto);
        } else {
            self.mission.start_next_run_at(i);
        }
        tracing::info!(index, "mission item made current");
        Ok(())
    }

    /// MAV_CMD_DO_LAND_START: AUTO from the mission's DO_LAND_START nearest the vehicle, as
    /// ArduCopter's `jump_to_landing_sequence_auto_RTL` (which it reports as mode AUTO RTL, 27;
    /// Kestrel reports AUTO). Refused, in ArduCopter's words, without a landing sequence, and
    /// whenever AUTO could not be entered (disarmed, no position, a failsafe). Held by
    /// `tests::mission::do_land_start_flies_the_nearest_landing_sequence_in_auto`.
    pub(super) fn jump_to_landing_sequence(&mut self, now: Time) -> Result<(), Refusal> {
        if !self.armed {
            return refuse("AUTO RTL refused: not armed");
        }
        self.mode_allowed(now, FlightMode::Auto)?;
        let (Some(nav), Some(frame)) = (self.nav.latest(), self.home.frame()) else {
            return refuse("AUTO RTL refused: no position");
        };
        let pos = nalgebra::Vector3::from(nav.position_ned_m);
        let home = self.home.ned().unwrap_or(pos);
        let mut runner = match self.mission.runner.take() {
            Some(runner) if self.mode == FlightMode::Auto => runner,
            other => {
                self.mission.runner = other;
                match self.mission.new_runner() {
                    Some(runner) => runner,
                    None => return refuse("Auto needs a mission"),
                }
            }
        };
        let jumped = runner.jump_to_landing_sequence(&pos, &frame, &home);
        if !jumped {
            if self.mode == FlightMode::Auto {
                self.mission.runner = Some(runner);
            }
            return refuse("Mode change to AUTO RTL failed: No landing sequence found");
        }
        if self.mode != FlightMode::Auto {
            self.geofence.manual_recovery_start(now);
        }
        self.boot_mode = false;
        // Drop what the mode before latched (a landing under way, a held position).
        self.enter(FlightMode::Auto);
        self.mission.runner = Some(runner);
        self.announce("Landing sequence start".to_owned());
        tracing::info!(index = ?self.mission.progress().current, "landing sequence");
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::Time;
    use kestrel_proto::messages::{MissionItem, MissionProgress};

    use super::*;

    fn mission(items: usize) -> Mission {
        Mission { time: Time::ZERO, items: vec![MissionItem::ReturnToLaunch; items], cruise_speed_m_s: 5.0 }
    }

    #[test]
    fn an_upload_on_the_ground_reports_its_progress_and_starts_no_run() {
        let mut m = MissionState::default();
        assert!(m.new_runner().is_none(), "no mission, no run");
        assert!(!m.upload(mission(3), false));
        assert!(m.runner.is_none());
        assert_eq!(m.progress().total, 3);
        assert_eq!(m.progress().current, 0);
    }

    #[test]
    fn the_item_made_current_starts_the_next_run_and_a_new_upload_forgets_it() {
        let mut m = MissionState::default();
        m.upload(mission(3), false);
        m.start_next_run_at(2);
        assert_eq!(m.progress().current, 2, "reported before the run");
        m.start_run();
        assert_eq!(m.runner.as_ref().map(|r| r.progress().current), Some(2));
        m.upload(mission(4), false);
        m.start_run();
        assert_eq!(m.runner.as_ref().map(|r| r.progress().current), Some(0));
    }

    #[test]
    fn an_upload_while_flown_replaces_the_run_and_clear_forgets_everything_but_a_pause() {
        let mut m = MissionState::default();
        m.upload(mission(3), false);
        m.start_next_run_at(1);
        m.start_run();
        m.paused = true;
        assert!(m.upload(mission(5), true), "the run goes on");
        assert_eq!(m.progress().total, 5);
        assert_eq!(m.progress().current, 1, "from the same item");
        m.clear();
        assert!(m.uploaded.is_none() && m.runner.is_none() && m.start.is_none());
        assert_eq!(m.progress(), MissionProgress::default());
        assert!(m.paused, "a pause is the mode's, cleared by a mode change");
    }
}
