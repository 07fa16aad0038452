//! What a flight report holds: the sections and entries `kestrel run --report FILE.json`
//! writes, in the field layout other tools rely on (docs/design.md). Each section is `None`
//! (`null` in JSON) when the part it scores did not run; the lists are empty then.
//!
//! Plain serde data: [`super::scoring`] computes the figures, [`super::actor`] collects them
//! from the graph's topics.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::attitude_source::AttitudeSourceSection;
use crate::estimator_events::EstimatorEvent;

/// The report, in the field layout other tools rely on (docs/design.md).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FlightReport {
    pub mission: Option<MissionSection>,
    pub flight: Option<FlightSection>,
    pub estimator: Option<EstimatorSection>,
    pub control: Option<ControlSection>,
    pub avoidance: Option<AvoidanceSection>,
    pub failsafes: Vec<FailsafeEntry>,
    /// Every start and end of a simulated fault (world file `[[faults]]`), in order; empty
    /// without a simulator or faults.
    #[serde(default)]
    pub faults: Vec<FaultEntry>,
    /// What the estimator noticed, in order; empty without an estimator.
    #[serde(default)]
    pub estimator_events: Vec<EstimatorEvent>,
    /// Each motor the commander's failure detector declared failed (`VehicleStatus::failed_motor`),
    /// when first reported; empty without ESC telemetry or failures. A hexa flies on without
    /// a failsafe, so this is where its failure shows.
    #[serde(default)]
    pub motor_failures: Vec<MotorFailureEntry>,
    /// Every actor failure, restart and give-up the supervisor published, in order: where a
    /// restarted actor that is not flight-critical (the stereo worker) shows.
    #[serde(default)]
    pub actor_events: Vec<ActorEventEntry>,
    /// What the commander announced (a refusal, the avoider's stale hold), in order.
    #[serde(default)]
    pub notices: Vec<NoticeEntry>,
    /// Which attitude flew (the estimator's, or the controller's backup while the estimator's
    /// was gone), when it switched, and the backup's error against the truth; `null` without
    /// any NavState.
    #[serde(default)]
    pub attitude_source: Option<AttitudeSourceSection>,
}

/// A supervisor event.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ActorEventEntry {
    /// Graph time of the event (s).
    pub t_s: f64,
    pub actor: String,
    /// `failed`, `restarted`, `gave_up` or `stopped`.
    pub event: String,
    /// The error or panic message.
    pub reason: String,
}

/// A commander announcement (`VehicleStatus::last_refusal`, counted by `refusals`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NoticeEntry {
    /// Graph time of the status that carried it (s).
    pub t_s: f64,
    pub text: String,
}

/// A motor declared failed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MotorFailureEntry {
    /// Graph time of the status that first reported it (s).
    pub t_s: f64,
    /// The motor, 1-based as the frame's motor table and the simulator's faults number them.
    pub motor: u32,
}

/// A simulated fault starting or ending.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FaultEntry {
    /// Graph time it took effect (s).
    pub t_s: f64,
    /// `started` or `ended`.
    pub phase: String,
    /// The world file's `kind`.
    pub kind: String,
    /// The kind's values as the world file spells them.
    pub values: String,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MissionSection {
    pub completed: bool,
    pub items_reached: u32,
    pub items_total: u32,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FlightSection {
    /// Graph time from the first message to the end of the run (s).
    pub duration_s: f64,
    pub collisions: u32,
    /// Smallest distance to an obstacle surface (m); `None` in a world without obstacles.
    pub min_clearance_m: Option<f64>,
    /// Whether the vehicle ended on the ground, intact.
    pub landed: bool,
    /// Horizontal distance of the final position from home (m).
    pub landing_distance_from_home_m: f64,
    pub crashed: bool,
    /// Largest distance of the true position from the straight leg between consecutive
    /// position targets (m); `None` when no leg was flown.
    pub tracking_error_max_m: Option<f64>,
    /// RMS of the same distance over the ground-truth samples on a leg (m).
    pub tracking_error_rms_m: Option<f64>,
    /// Horizontal length of the true path flown while airborne (m).
    pub path_length_m: f64,
    /// Horizontal straight-line distance from where the vehicle left the ground to where it
    /// ended (m): with `path_length_m`, how far avoiding obstacles made it go round.
    pub straight_line_m: f64,
    /// Largest true angle of the thrust axis from vertical while airborne (degrees).
    #[serde(default)]
    pub max_tilt_deg: f64,
    /// The last touchdown: true downward speed (m/s) and tilt (degrees) of the last airborne
    /// ground-truth sample before it; `None` without one.
    #[serde(default)]
    pub touchdown: Option<Touchdown>,
}

/// How the vehicle met the ground, from the ground truth just before.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Touchdown {
    pub speed_down_m_s: f64,
    pub tilt_deg: f64,
}

/// Root-mean-square estimation errors against ground truth, over the samples where the
/// estimator had an origin and a valid attitude.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct EstimatorSection {
    pub rms_horizontal_m: f64,
    pub rms_vertical_m: f64,
    pub rms_velocity_m_s: f64,
    pub rms_roll_pitch_deg: f64,
    pub rms_yaw_deg: f64,
    /// Largest horizontal position error (m): how far a fault (a GPS jump or loss) took the
    /// estimate from the truth at worst.
    #[serde(default)]
    pub max_horizontal_m: f64,
    /// Ground-truth samples compared.
    pub samples: u64,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ControlSection {
    pub period_p50_us: f64,
    pub period_p99_us: f64,
    pub period_max_us: f64,
    pub overruns: u64,
    /// Wall-clock time one iteration took, 99th percentile (µs).
    #[serde(default)]
    pub execution_p99_us: f64,
    /// What the loop thread got of the OS (all false / `None` in lockstep): SCHED_FIFO,
    /// memory locked (`mlockall`), the CPU it is pinned to.
    #[serde(default)]
    pub sched_fifo: bool,
    #[serde(default)]
    pub memory_locked: bool,
    #[serde(default)]
    pub pinned_cpu: Option<u32>,
    /// Iterations flown, and the longest one took (µs, wall clock).
    #[serde(default)]
    pub iterations: u64,
    #[serde(default)]
    pub execution_max_us: f64,
    /// Age of the NavState each iteration ran on, from its IMU sample's measurement (µs; 0 in
    /// lockstep), and the iterations the watchdog ran without a new one.
    #[serde(default)]
    pub nav_age_p50_us: f64,
    #[serde(default)]
    pub nav_age_p99_us: f64,
    #[serde(default)]
    pub watchdog_steps: u64,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct AvoidanceSection {
    /// Stereo frame → first setpoint using its avoidance command, host wall clock
    /// ([`crate::frame_latency`]).
    pub frame_to_setpoint_p50_ms: f64,
    pub frame_to_setpoint_p95_ms: f64,
    /// Frames the latency was measured on.
    pub samples: usize,
    /// Simulated seconds per host second from the first stereo frame to the last: how much
    /// faster than real time the graph ran with the camera rendering and stereo matching
    /// (the perception simulation's real-time factor); `None` under two frames.
    #[serde(default)]
    pub realtime_factor: Option<f64>,
    /// Simulated seconds the commander's forward speed cap held the vehicle below what the
    /// leg or the sticks asked for, in all and per reason (`ClearRangeReason`'s
    /// names: what the range ahead was taken from).
    #[serde(default)]
    pub speed_capped_s: f64,
    #[serde(default)]
    pub speed_capped_s_by_reason: BTreeMap<String, f64>,
    /// Lowest cap (m/s) while it held the vehicle back; `None` if it never did.
    #[serde(default)]
    pub lowest_speed_cap_m_s: Option<f64>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FailsafeEntry {
    pub t_s: f64,
    pub cause: String,
    pub action: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_report_of_nothing_has_the_documented_sections_as_null_and_the_lists_empty() {
        // docs/design.md: every section present, `null` where the part did not run.
        let json = serde_json::to_value(FlightReport::default()).unwrap();
        for section in ["mission", "flight", "estimator", "control", "avoidance", "attitude_source"] {
            assert_eq!(json[section], serde_json::Value::Null, "{section}");
        }
        for list in ["failsafes", "faults", "estimator_events", "motor_failures", "actor_events", "notices"] {
            assert_eq!(json[list], serde_json::json!([]), "{list}");
        }
    }

    #[test]
    fn the_documented_fields_keep_their_names() {
        let report = FlightReport {
            mission: Some(MissionSection { completed: true, items_reached: 3, items_total: 3 }),
            flight: Some(FlightSection { min_clearance_m: Some(1.5), ..Default::default() }),
            estimator: Some(EstimatorSection::default()),
            control: Some(ControlSection::default()),
            avoidance: Some(AvoidanceSection::default()),
            failsafes: vec![FailsafeEntry { t_s: 1.0, cause: "gps_lost".into(), action: "land".into() }],
            ..Default::default()
        };
        let json = serde_json::to_value(&report).unwrap();
        let fields = [
            ("mission", &["completed", "items_reached", "items_total"][..]),
            (
                "flight",
                &["duration_s", "collisions", "min_clearance_m", "landed", "landing_distance_from_home_m"],
            ),
            (
                "estimator",
                &[
                    "rms_horizontal_m",
                    "rms_vertical_m",
                    "rms_velocity_m_s",
                    "rms_roll_pitch_deg",
                    "rms_yaw_deg",
                ],
            ),
            ("control", &["period_p50_us", "period_p99_us", "overruns"]),
            ("avoidance", &["frame_to_setpoint_p50_ms", "frame_to_setpoint_p95_ms"]),
        ];
        for (section, names) in fields {
            for name in names {
                assert!(json[section].get(name).is_some(), "{section}.{name} in {json:#}");
            }
        }
        assert_eq!(json["failsafes"][0]["cause"], "gps_lost");
        assert_eq!(json["failsafes"][0]["action"], "land");
    }

    #[test]
    fn a_report_reads_back_as_written_and_older_reports_without_the_later_fields_still_read() {
        let report = FlightReport {
            flight: Some(FlightSection {
                duration_s: 12.5,
                touchdown: Some(Touchdown { speed_down_m_s: 0.4, tilt_deg: 2.0 }),
                ..Default::default()
            }),
            motor_failures: vec![MotorFailureEntry { t_s: 3.0, motor: 2 }],
            ..Default::default()
        };
        let json = serde_json::to_string(&report).unwrap();
        assert_eq!(serde_json::from_str::<FlightReport>(&json).unwrap(), report);
        let old = r#"{ "mission": null, "flight": null, "estimator": null, "control": null,
                       "avoidance": null, "failsafes": [] }"#;
        assert_eq!(serde_json::from_str::<FlightReport>(old).unwrap(), FlightReport::default());
    }
}
