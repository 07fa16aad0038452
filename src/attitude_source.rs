//! Which attitude flew, for the flight report: the estimator's NavState, or the controller's
//! backup attitude (`kestrel_control::backup_attitude`) while the estimator's was gone, when it
//! switched, and how far the backup was from the truth while it flew.
//!
//! The controller publishes the backup's state (`backup_nav_state`) only on the iterations it
//! flies on it, so the first of them is the switch to the backup and the next estimator state
//! with a valid attitude the switch back.

use kestrel_proto::Time;
use kestrel_proto::attitude::{angle_difference_rad, euler_rad};
use kestrel_proto::messages::{GroundTruth, NavState};
use serde::{Deserialize, Serialize};

/// `attitude_source` in the report.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct AttitudeSourceSection {
    /// Flying at the end: `"estimator"` or `"backup"`.
    pub flown: String,
    /// Every switch, in order.
    pub switches: Vec<AttitudeSwitch>,
    /// Time flown on the backup (s).
    pub backup_s: f64,
    /// The backup against the truth while it flew (deg): RMS of the roll and pitch errors, the
    /// largest of either, RMS of the heading error; `null` when it never flew.
    pub backup_rms_roll_pitch_deg: Option<f64>,
    pub backup_max_roll_pitch_deg: Option<f64>,
    pub backup_rms_yaw_deg: Option<f64>,
}

/// A switch of the attitude flown.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AttitudeSwitch {
    pub t_s: f64,
    /// `"estimator"` or `"backup"`.
    pub to: String,
}

/// What the report keeps of the attitude sources.
#[derive(Debug, Default)]
pub struct AttitudeSources {
    /// The backup is flying; `None` before any state came.
    on_backup: Option<bool>,
    switches: Vec<AttitudeSwitch>,
    last_backup: Option<Time>,
    backup_s: f64,
    roll_pitch_sq: f64,
    roll_pitch_max: f64,
    yaw_sq: f64,
    samples: u64,
}

/// Gaps between backup states longer than this (s) are not counted as time flown on it.
const MAX_GAP_S: f64 = 0.1;

impl AttitudeSources {
    /// An estimator state; one with a valid attitude is flown.
    pub fn on_estimator(&mut self, nav: &NavState) {
        if !nav.valid.attitude {
            return;
        }
        if self.on_backup == Some(true) {
            self.switches.push(AttitudeSwitch { t_s: nav.time.as_secs_f64(), to: "estimator".into() });
        }
        self.on_backup = Some(false);
    }

    /// A backup state (one the loop flew on), scored against `truth` of its instant if known.
    pub fn on_backup(&mut self, nav: &NavState, truth: Option<&GroundTruth>) {
        if self.on_backup != Some(true) {
            self.switches.push(AttitudeSwitch { t_s: nav.time.as_secs_f64(), to: "backup".into() });
        }
        self.on_backup = Some(true);
        if let Some(last) = self.last_backup {
            let dt = nav.time.saturating_since(last).as_secs_f64();
            if dt <= MAX_GAP_S {
                self.backup_s += dt;
            }
        }
        self.last_backup = Some(nav.time);
        if let Some(truth) = truth {
            let (est, tru) = (euler_rad(nav.attitude), euler_rad(truth.attitude));
            let roll = angle_difference_rad(est[0], tru[0]);
            let pitch = angle_difference_rad(est[1], tru[1]);
            self.roll_pitch_sq += (roll * roll + pitch * pitch) / 2.0;
            self.roll_pitch_max = self.roll_pitch_max.max(roll.abs()).max(pitch.abs());
            self.yaw_sq += angle_difference_rad(est[2], tru[2]).powi(2);
            self.samples += 1;
        }
    }

    /// The section; `None` before any state came.
    pub fn section(&self) -> Option<AttitudeSourceSection> {
        let on_backup = self.on_backup?;
        let scored = self.samples > 0;
        let rms = |sum: f64| (sum / self.samples as f64).sqrt().to_degrees();
        Some(AttitudeSourceSection {
            flown: if on_backup { "backup" } else { "estimator" }.into(),
            switches: self.switches.clone(),
            backup_s: self.backup_s,
            backup_rms_roll_pitch_deg: scored.then(|| rms(self.roll_pitch_sq)),
            backup_max_roll_pitch_deg: scored.then(|| self.roll_pitch_max.to_degrees()),
            backup_rms_yaw_deg: scored.then(|| rms(self.yaw_sq)),
        })
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::attitude::quaternion_from_euler;

    use super::*;

    fn nav(t_s: f64, roll: f64) -> NavState {
        let time = Time::from_micros((t_s * 1e6) as u64);
        NavState::exact(time, quaternion_from_euler(roll, 0.0, 0.0), [0.0; 3], [0.0; 3], [0.0; 3])
    }

    #[test]
    fn switches_are_listed_with_the_time_flown_on_the_backup_and_its_error() {
        let mut s = AttitudeSources::default();
        assert_eq!(s.section(), None);
        s.on_estimator(&nav(1.0, 0.0));
        assert_eq!(s.section().expect("seen").flown, "estimator");
        let mut truth =
            GroundTruth { attitude: quaternion_from_euler(0.0, 0.0, 0.0), ..GroundTruth::default() };
        for k in 0..=100 {
            let t = 2.0 + k as f64 * 0.01;
            truth.time = Time::from_micros((t * 1e6) as u64);
            s.on_backup(&nav(t, 0.02), Some(&truth));
        }
        let section = s.section().expect("seen");
        assert_eq!(section.flown, "backup");
        assert!((section.backup_s - 1.0).abs() < 1e-6, "{}", section.backup_s);
        // Roll off by 0.02 rad, pitch exact: RMS over the two is 0.02/√2.
        let rms = section.backup_rms_roll_pitch_deg.expect("scored");
        assert!((rms - (0.02f64 / 2f64.sqrt()).to_degrees()).abs() < 1e-9, "{rms}");
        assert!((section.backup_max_roll_pitch_deg.expect("scored") - 0.02f64.to_degrees()).abs() < 1e-9);
        s.on_estimator(&nav(5.0, 0.0));
        let section = s.section().expect("seen");
        let to: Vec<_> = section.switches.iter().map(|w| (w.t_s, w.to.as_str())).collect();
        assert_eq!(to, [(2.0, "backup"), (5.0, "estimator")]);
    }
}
