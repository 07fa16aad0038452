//! The machine-readable flight report (`kestrel run --report FILE.json`): did the mission
//! complete, did the vehicle hit anything, how far was the estimate from the truth, how
//! regular was the control loop, which failsafes fired, and which simulated faults were
//! injected when (the simulator's `sim_fault`), and what the estimator noticed when
//! (`estimator_status`, see [`crate::estimator_events`]), which actors the supervisor restarted
//! (`supervisor`), what the commander announced (its status's refusals and notices, each a
//! STATUSTEXT on the link), and which attitude flew — the estimator's or the controller's backup
//! (`backup_nav_state`, see [`crate::attitude_source`]) — and when it switched.
//!
//! It is an ordinary actor fed through queue mailboxes, so under lockstep it sees every
//! message and the report of a simulated flight is as repeatable as the flight itself. Each
//! section is `null` when the part it scores did not run.

use std::collections::{BTreeMap, VecDeque};
use std::path::PathBuf;
use std::time::Instant;

use kestrel_proto::attitude::{angle_difference_rad, euler_rad, tilt_rad, unit_quaternion};
use kestrel_proto::geo::{Geodetic, LocalFrame};
use kestrel_proto::messages::{
    AvoidanceCommand, ControlLoopStats, EstimatorStatus, GroundTruth, NavState, Setpoint, SetpointTarget,
    SimFault, StereoFrame, SupervisorEvent, VehicleStatus,
};
use kestrel_proto::{Actor, ActorError, Context, Setup, Time};
use serde::{Deserialize, Serialize};

use crate::attitude_source::{AttitudeSourceSection, AttitudeSources};
use crate::estimator_events::{EstimatorEvent, EstimatorEvents};
use crate::frame_latency::FrameLatency;
use crate::serde_name::serde_name;

/// `params` of the report actor.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FlightReportParams {
    /// Where the JSON report is written when the run ends.
    pub out: PathBuf,
}

/// The topics the report reads, with their message types, so the runtime can route the ones
/// a graph has.
pub const REPORT_INPUTS: [(&str, &str); 11] = [
    ("ground_truth", <GroundTruth as kestrel_proto::Message>::TYPE_NAME),
    ("nav_state", <NavState as kestrel_proto::Message>::TYPE_NAME),
    ("vehicle_status", <VehicleStatus as kestrel_proto::Message>::TYPE_NAME),
    ("control_loop_stats", <ControlLoopStats as kestrel_proto::Message>::TYPE_NAME),
    ("setpoint", <Setpoint as kestrel_proto::Message>::TYPE_NAME),
    ("stereo_frame", <StereoFrame as kestrel_proto::Message>::TYPE_NAME),
    ("avoidance_command", <AvoidanceCommand as kestrel_proto::Message>::TYPE_NAME),
    ("sim_fault", <SimFault as kestrel_proto::Message>::TYPE_NAME),
    ("estimator_status", <EstimatorStatus as kestrel_proto::Message>::TYPE_NAME),
    ("supervisor", <SupervisorEvent as kestrel_proto::Message>::TYPE_NAME),
    ("backup_nav_state", <NavState as kestrel_proto::Message>::TYPE_NAME),
];

/// What the report actor handles.
#[derive(Debug)]
pub enum ReportInput {
    Truth(GroundTruth),
    Nav(Box<NavState>),
    Status(VehicleStatus),
    Loop(ControlLoopStats),
    Setpoint(Setpoint),
    Frame(StereoFrame),
    Avoidance(AvoidanceCommand),
    Fault(SimFault),
    Estimator(Box<EstimatorStatus>),
    Supervisor(SupervisorEvent),
    /// The controller's backup attitude, on the iterations it flew on it.
    BackupNav(Box<NavState>),
}

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

/// Sums of squared errors.
#[derive(Default)]
struct ErrorSums {
    horizontal: f64,
    /// Largest horizontal error (m), not squared.
    horizontal_max: f64,
    vertical: f64,
    velocity: f64,
    roll_pitch: f64,
    yaw: f64,
    samples: u64,
}

/// Cross-track error along the legs the commander flies: from one position target to the next.
#[derive(Default)]
struct Tracking {
    /// The previous and the current position target (m, NED in the estimator's frame).
    leg: (Option<[f64; 3]>, Option<[f64; 3]>),
    max_m: f64,
    sum_sq: f64,
    samples: u64,
}

impl Tracking {
    /// A new setpoint: a full position target extends the path; anything else (a velocity-
    /// controlled axis while landing, attitude or rate control) is not a path to track.
    fn on_setpoint(&mut self, target: Option<[f64; 3]>) {
        match target {
            Some(t) if self.leg.1 != Some(t) => self.leg = (self.leg.1, Some(t)),
            Some(_) => {}
            None => self.leg = (None, None),
        }
    }

    /// Adds the distance of `p` from the current leg.
    fn on_position(&mut self, p: [f64; 3]) {
        let (Some(a), Some(b)) = self.leg else { return };
        let ab = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let ap = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
        let length_sq: f64 = ab.iter().map(|x| x * x).sum();
        let along = if length_sq > 0.0 {
            (ab.iter().zip(&ap).map(|(x, y)| x * y).sum::<f64>() / length_sq).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let distance = (0..3).map(|i| (ap[i] - along * ab[i]).powi(2)).sum::<f64>().sqrt();
        self.max_m = self.max_m.max(distance);
        self.sum_sq += distance * distance;
        self.samples += 1;
    }
}

/// The truth at `time`: the sample stamped then (lockstep: the simulator and the estimator
/// share the IMU's instants), else, as on the wall clock where a driver stamps its own reads,
/// position and velocity interpolated between the samples either side and the nearer one's
/// attitude. `None` outside the window.
fn truth_at(window: &VecDeque<GroundTruth>, time: Time) -> Option<GroundTruth> {
    if let Some(exact) = window.iter().find(|t| t.time == time) {
        return Some(exact.clone());
    }
    let after = window.iter().position(|t| t.time > time)?;
    let (a, b) = (window.get(after.checked_sub(1)?)?, &window[after]);
    if a.time > time {
        return None;
    }
    let span = (b.time.as_micros() - a.time.as_micros()) as f64;
    let w = (time.as_micros() - a.time.as_micros()) as f64 / span;
    let mix = |x: f64, y: f64| x + (y - x) * w;
    let mut t = if w < 0.5 { a.clone() } else { b.clone() };
    t.time = time;
    t.lat_deg = mix(a.lat_deg, b.lat_deg);
    t.lon_deg = mix(a.lon_deg, b.lon_deg);
    t.alt_msl_m = mix(a.alt_msl_m, b.alt_msl_m);
    t.velocity_ned_m_s = std::array::from_fn(|i| mix(a.velocity_ned_m_s[i], b.velocity_ned_m_s[i]));
    t.position_ned_m = std::array::from_fn(|i| mix(a.position_ned_m[i], b.position_ned_m[i]));
    Some(t)
}

/// Collects the report while the graph runs and writes it on stop.
pub struct FlightReportActor {
    out: PathBuf,
    first: Option<Time>,
    last: Time,
    /// Recent ground truth, to pair each NavState with the truth of the same instant.
    truth: VecDeque<GroundTruth>,
    latest_truth: Option<GroundTruth>,
    /// NavStates newer than the latest truth, scored when it catches up (wall-clock runs).
    waiting: VecDeque<NavState>,
    min_clearance_m: Option<f64>,
    errors: ErrorSums,
    tracking: Tracking,
    /// The estimator's frame, in which setpoints are given.
    nav_frame: Option<LocalFrame>,
    status: Option<VehicleStatus>,
    loop_stats: Option<ControlLoopStats>,
    failsafes: Vec<FailsafeEntry>,
    faults: Vec<FaultEntry>,
    estimator_events: EstimatorEvents,
    motor_failures: Vec<MotorFailureEntry>,
    actor_events: Vec<ActorEventEntry>,
    notices: Vec<NoticeEntry>,
    attitude_sources: AttitudeSources,
    frame_latency: FrameLatency,
    speed_cap: SpeedCapTally,
    /// Graph time and host time of the first and the latest stereo frame.
    frames_span: Option<[(Time, Instant); 2]>,
    /// Horizontal true path while airborne (m) and its first and latest points (NED, m).
    path_length_m: f64,
    airborne_first: Option<[f64; 2]>,
    airborne_last: Option<[f64; 2]>,
    max_tilt_deg: f64,
    /// The latest airborne sample's downward speed and tilt, and the last touchdown.
    airborne_touchdown: Option<Touchdown>,
    touchdown: Option<Touchdown>,
}

/// Angle of the body's down axis from NED down (degrees) for the attitude `[w, x, y, z]`; NaN
/// for one that is no rotation (the simulator's truth always is; `f64::max` passes NaN over).
fn tilt_deg(q: [f64; 4]) -> f64 {
    unit_quaternion(q).map_or(f64::NAN, |q| tilt_rad(&q).to_degrees())
}

/// The speed cap's account from the commander's statuses: a status whose cap limits counts
/// until the next status.
#[derive(Debug, Default)]
struct SpeedCapTally {
    by_reason: BTreeMap<String, f64>,
    lowest_m_s: Option<f64>,
}

impl SpeedCapTally {
    fn on_status(&mut self, previous: Option<&VehicleStatus>, status: &VehicleStatus) {
        if let Some((p, cap)) = previous.and_then(|p| Some((p, p.speed_cap.filter(|c| c.limiting)?))) {
            let dt_s = status.time.saturating_since(p.time).as_secs_f64();
            *self.by_reason.entry(serde_name(&cap.reason)).or_default() += dt_s;
        }
        if let Some(cap) = status.speed_cap.filter(|c| c.limiting) {
            self.lowest_m_s = Some(self.lowest_m_s.map_or(cap.cap_m_s, |l| l.min(cap.cap_m_s)));
        }
    }
}

/// Ground truth kept for pairing: 1 s at the simulator's 50 Hz default.
const TRUTH_WINDOW: usize = 64;

impl FlightReportActor {
    fn seen(&mut self, t: Time) {
        self.first.get_or_insert(t);
        self.last = self.last.max(t);
    }

    fn on_truth(&mut self, truth: GroundTruth) {
        self.seen(truth.time);
        if let Some(frame) = &self.nav_frame {
            let here = Geodetic { lat_deg: truth.lat_deg, lon_deg: truth.lon_deg, alt_m: truth.alt_msl_m };
            self.tracking.on_position(frame.to_ned(here));
        }
        if let Some(c) = truth.clearance_m {
            self.min_clearance_m = Some(self.min_clearance_m.map_or(c, |m: f64| m.min(c)));
        }
        if truth.landed {
            self.touchdown = self.airborne_touchdown.take().or(self.touchdown);
        } else {
            let tilt = tilt_deg(truth.attitude);
            self.max_tilt_deg = self.max_tilt_deg.max(tilt);
            self.airborne_touchdown =
                Some(Touchdown { speed_down_m_s: truth.velocity_ned_m_s[2], tilt_deg: tilt });
            let here = [truth.position_ned_m[0], truth.position_ned_m[1]];
            if let Some(last) = self.airborne_last {
                self.path_length_m += (here[0] - last[0]).hypot(here[1] - last[1]);
            }
            self.airborne_first.get_or_insert(here);
            self.airborne_last = Some(here);
        }
        if self.truth.len() == TRUTH_WINDOW {
            self.truth.pop_front();
        }
        self.truth.push_back(truth.clone());
        let time = truth.time;
        self.latest_truth = Some(truth);
        while let Some(nav) = self.waiting.front().filter(|n| n.time <= time).cloned() {
            self.waiting.pop_front();
            if let Some(origin) = nav.origin {
                self.score(&nav, origin);
            }
        }
    }

    fn on_nav(&mut self, nav: &NavState) {
        self.seen(nav.time);
        self.attitude_sources.on_estimator(nav);
        let (Some(origin), true) = (nav.origin, nav.valid.attitude) else { return };
        if self.nav_frame.is_none_or(|f| f.home() != origin) {
            self.nav_frame = Some(LocalFrame::new(origin));
        }
        // On the wall clock a NavState can come before the truth after its instant: it waits.
        if self.latest_truth.as_ref().is_some_and(|t| t.time < nav.time) {
            if self.waiting.len() == TRUTH_WINDOW {
                self.waiting.pop_front();
            }
            self.waiting.push_back(nav.clone());
            return;
        }
        self.score(nav, origin);
    }

    /// Adds `nav`'s errors against the truth of its instant.
    fn score(&mut self, nav: &NavState, origin: Geodetic) {
        let Some(truth) = truth_at(&self.truth, nav.time) else { return };
        let frame = LocalFrame::new(origin);
        let true_ned =
            frame.to_ned(Geodetic { lat_deg: truth.lat_deg, lon_deg: truth.lon_deg, alt_m: truth.alt_msl_m });
        let d = |i: usize| nav.position_ned_m[i] - true_ned[i];
        let dv = |i: usize| nav.velocity_ned_m_s[i] - truth.velocity_ned_m_s[i];
        let (est, tru) = (euler_rad(nav.attitude), euler_rad(truth.attitude));
        let e = &mut self.errors;
        e.horizontal += d(0).powi(2) + d(1).powi(2);
        e.horizontal_max = e.horizontal_max.max(d(0).hypot(d(1)));
        e.vertical += d(2).powi(2);
        e.velocity += dv(0).powi(2) + dv(1).powi(2) + dv(2).powi(2);
        e.roll_pitch += (angle_difference_rad(est[0], tru[0]).powi(2)
            + angle_difference_rad(est[1], tru[1]).powi(2))
            / 2.0;
        e.yaw += angle_difference_rad(est[2], tru[2]).powi(2);
        e.samples += 1;
    }

    fn on_status(&mut self, status: VehicleStatus) {
        self.seen(status.time);
        let previous = self.status.as_ref().and_then(|s| s.failsafe);
        if let Some(f) =
            status.failsafe.filter(|f| previous.is_none_or(|p| p.cause != f.cause || p.action != f.action))
        {
            self.failsafes.push(FailsafeEntry {
                t_s: f.since.as_secs_f64(),
                cause: serde_name(&f.cause),
                action: serde_name(&f.action),
            });
        }
        if let Some(text) = status
            .last_refusal
            .as_ref()
            .filter(|_| self.status.as_ref().is_none_or(|s| s.refusals != status.refusals))
        {
            self.notices.push(NoticeEntry { t_s: status.time.as_secs_f64(), text: text.clone() });
        }
        let known = self.status.as_ref().and_then(|s| s.failed_motor);
        if let Some(motor) = status.failed_motor.filter(|m| known != Some(*m)) {
            self.motor_failures
                .push(MotorFailureEntry { t_s: status.time.as_secs_f64(), motor: u32::from(motor) + 1 });
        }
        self.speed_cap.on_status(self.status.as_ref(), &status);
        self.status = Some(status);
    }

    /// The report as it stands.
    pub fn report(&self) -> FlightReport {
        let flight = self.latest_truth.as_ref().map(|t| FlightSection {
            duration_s: self.last.saturating_since(self.first.unwrap_or(self.last)).as_secs_f64(),
            collisions: t.collisions,
            min_clearance_m: self.min_clearance_m,
            landed: t.landed && !t.crashed,
            landing_distance_from_home_m: t.position_ned_m[0].hypot(t.position_ned_m[1]),
            crashed: t.crashed,
            tracking_error_max_m: (self.tracking.samples > 0).then_some(self.tracking.max_m),
            tracking_error_rms_m: (self.tracking.samples > 0)
                .then(|| (self.tracking.sum_sq / self.tracking.samples as f64).sqrt()),
            path_length_m: self.path_length_m,
            straight_line_m: match (self.airborne_first, self.airborne_last) {
                (Some(a), Some(b)) => (b[0] - a[0]).hypot(b[1] - a[1]),
                _ => 0.0,
            },
            max_tilt_deg: self.max_tilt_deg,
            touchdown: self.touchdown,
        });
        let e = &self.errors;
        let rms = |sum: f64| (sum / e.samples as f64).sqrt();
        let estimator = (e.samples > 0).then(|| EstimatorSection {
            rms_horizontal_m: rms(e.horizontal),
            rms_vertical_m: rms(e.vertical),
            rms_velocity_m_s: rms(e.velocity),
            rms_roll_pitch_deg: rms(e.roll_pitch).to_degrees(),
            rms_yaw_deg: rms(e.yaw).to_degrees(),
            max_horizontal_m: e.horizontal_max,
            samples: e.samples,
        });
        FlightReport {
            mission: self.status.as_ref().map(|s| MissionSection {
                completed: s.mission.completed,
                items_reached: s.mission.reached,
                items_total: s.mission.total,
            }),
            flight,
            estimator,
            control: self.loop_stats.as_ref().map(|l| ControlSection {
                period_p50_us: l.period_p50_us,
                period_p99_us: l.period_p99_us,
                period_max_us: l.period_max_us,
                overruns: l.overruns,
                execution_p99_us: l.execution_p99_us,
                sched_fifo: l.realtime_priority,
                memory_locked: l.memory_locked,
                pinned_cpu: l.pinned_cpu,
                iterations: l.iterations,
                execution_max_us: l.execution_max_us,
                nav_age_p50_us: l.nav_age_p50_us,
                nav_age_p99_us: l.nav_age_p99_us,
                watchdog_steps: l.watchdog_steps,
            }),
            avoidance: self.frame_latency.percentiles_ms().map(|(p50, p95)| AvoidanceSection {
                frame_to_setpoint_p50_ms: p50,
                frame_to_setpoint_p95_ms: p95,
                samples: self.frame_latency.samples(),
                realtime_factor: self.frames_span.and_then(|[(t0, h0), (t1, h1)]| {
                    let host_s = h1.duration_since(h0).as_secs_f64();
                    (host_s > 0.0).then(|| t1.saturating_since(t0).as_secs_f64() / host_s)
                }),
                speed_capped_s: self.speed_cap.by_reason.values().sum(),
                speed_capped_s_by_reason: self.speed_cap.by_reason.clone(),
                lowest_speed_cap_m_s: self.speed_cap.lowest_m_s,
            }),
            failsafes: self.failsafes.clone(),
            faults: self.faults.clone(),
            estimator_events: self.estimator_events.log.clone(),
            motor_failures: self.motor_failures.clone(),
            actor_events: self.actor_events.clone(),
            notices: self.notices.clone(),
            attitude_source: self.attitude_sources.section(),
        }
    }
}

impl Actor for FlightReportActor {
    type Params = FlightReportParams;
    type Input = ReportInput;

    fn build(params: &FlightReportParams, setup: &mut impl Setup<ReportInput>) -> Result<Self, ActorError> {
        setup.input("ground_truth", ReportInput::Truth);
        setup.input("nav_state", |n| ReportInput::Nav(Box::new(n)));
        setup.input("vehicle_status", ReportInput::Status);
        setup.input("control_loop_stats", ReportInput::Loop);
        setup.input("setpoint", ReportInput::Setpoint);
        setup.input("stereo_frame", ReportInput::Frame);
        setup.input("avoidance_command", ReportInput::Avoidance);
        setup.input("sim_fault", ReportInput::Fault);
        setup.input("estimator_status", |s| ReportInput::Estimator(Box::new(s)));
        setup.input("supervisor", ReportInput::Supervisor);
        setup.input("backup_nav_state", |n| ReportInput::BackupNav(Box::new(n)));
        Ok(FlightReportActor {
            out: params.out.clone(),
            first: None,
            last: Time::ZERO,
            truth: VecDeque::with_capacity(TRUTH_WINDOW),
            waiting: VecDeque::with_capacity(TRUTH_WINDOW),
            latest_truth: None,
            min_clearance_m: None,
            errors: ErrorSums::default(),
            tracking: Tracking::default(),
            nav_frame: None,
            status: None,
            loop_stats: None,
            failsafes: Vec::new(),
            faults: Vec::new(),
            estimator_events: EstimatorEvents::default(),
            motor_failures: Vec::new(),
            actor_events: Vec::new(),
            notices: Vec::new(),
            attitude_sources: AttitudeSources::default(),
            frame_latency: FrameLatency::default(),
            frames_span: None,
            speed_cap: SpeedCapTally::default(),
            path_length_m: 0.0,
            airborne_first: None,
            airborne_last: None,
            max_tilt_deg: 0.0,
            airborne_touchdown: None,
            touchdown: None,
        })
    }

    async fn handle(&mut self, _ctx: &Context, input: ReportInput) -> Result<(), ActorError> {
        match input {
            ReportInput::Truth(t) => self.on_truth(t),
            ReportInput::Nav(n) => self.on_nav(&n),
            ReportInput::Status(s) => self.on_status(s),
            ReportInput::Frame(f) => {
                let now = Instant::now();
                self.frame_latency.on_frame(f.sequence, now);
                let first = self.frames_span.map_or((f.time, now), |[first, _]| first);
                self.frames_span = Some([first, (f.time, now)]);
            }
            ReportInput::Avoidance(a) => self.frame_latency.on_command(a.frame_sequence),
            ReportInput::Setpoint(sp) => {
                self.frame_latency.on_setpoint(Instant::now());
                self.tracking.on_setpoint(match sp.target {
                    SetpointTarget::Trajectory(t) => match t.position_ned_m {
                        [Some(n), Some(e), Some(d)] => Some([n, e, d]),
                        _ => None,
                    },
                    _ => None,
                })
            }
            ReportInput::Fault(f) => {
                self.seen(f.time);
                self.faults.push(FaultEntry {
                    t_s: f.time.as_secs_f64(),
                    phase: serde_name(&f.phase),
                    kind: f.kind,
                    values: f.values,
                });
            }
            ReportInput::Estimator(s) => {
                self.seen(s.time);
                self.estimator_events.on_status(&s);
            }
            ReportInput::Supervisor(e) => {
                self.seen(e.time);
                self.actor_events.push(ActorEventEntry {
                    t_s: e.time.as_secs_f64(),
                    actor: e.actor,
                    event: serde_name(&e.kind),
                    reason: e.reason,
                });
            }
            ReportInput::BackupNav(n) => {
                self.seen(n.time);
                let truth = truth_at(&self.truth, n.time);
                self.attitude_sources.on_backup(&n, truth.as_ref());
            }
            ReportInput::Loop(l) => {
                self.seen(l.time);
                self.loop_stats = Some(l);
            }
        }
        Ok(())
    }

    async fn stop(&mut self, _ctx: &Context) {
        let written = serde_json::to_string_pretty(&self.report())
            .map_err(std::io::Error::other)
            .and_then(|json| std::fs::write(&self.out, json + "\n"));
        match written {
            Ok(()) => tracing::info!(path = %self.out.display(), "flight report written"),
            Err(e) => tracing::error!(path = %self.out.display(), "cannot write the flight report: {e}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tilt_is_the_angle_of_body_down_from_ned_down() {
        let (roll, pitch, yaw) = (0.3f64, -0.5f64, 2.0f64);
        let ((sx, cx), (sy, cy), (sz, cz)) =
            ((roll / 2.0).sin_cos(), (pitch / 2.0).sin_cos(), (yaw / 2.0).sin_cos());
        // Yaw then roll (q_z · q_x): the tilt is the roll; pitch then roll (q_y · q_x): body down
        // is (.., .., cos θ · cos φ) in NED.
        let yawed_roll = [cz * cx, cz * sx, sz * sx, sz * cx];
        let pitched_roll = [cy * cx, cy * sx, sy * cx, -sy * sx];
        assert!((tilt_deg(yawed_roll) - roll.to_degrees()).abs() < 1e-9);
        assert!((tilt_deg(pitched_roll) - (pitch.cos() * roll.cos()).acos().to_degrees()).abs() < 1e-9);
        assert!(tilt_deg([sz, 0.0, 0.0, cz]) < 1e-9);
        assert!((tilt_deg([0.0, 1.0, 0.0, 0.0]) - 180.0).abs() < 1e-9);
    }
}
