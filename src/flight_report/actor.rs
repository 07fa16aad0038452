//! The report actor: an ordinary actor fed through queue mailboxes, so under lockstep it sees
//! every message and the report of a simulated flight is as repeatable as the flight itself. It
//! routes each topic to the tally in [`super::scoring`] that needs it, keeps the lists of what
//! happened when, and writes the [`FlightReport`] as JSON when the run stops.

use std::collections::VecDeque;
use std::path::PathBuf;
use std::time::Instant;

use kestrel_proto::geo::{Geodetic, LocalFrame};
use kestrel_proto::messages::{
    AvoidanceCommand, ControlLoopStats, EstimatorStatus, GroundTruth, NavState, Setpoint, SetpointTarget,
    SimFault, StereoFrame, SupervisorEvent, VehicleStatus,
};
use kestrel_proto::{Actor, ActorError, Context, Setup, Time};
use serde::Deserialize;

use super::schema::{
    ActorEventEntry, AvoidanceSection, ControlSection, FailsafeEntry, FaultEntry, FlightReport,
    FlightSection, MissionSection, MotorFailureEntry, NoticeEntry,
};
use super::scoring::{AirbornePath, ErrorSums, SpeedCapTally, Tracking, truth_at};
use crate::attitude_source::AttitudeSources;
use crate::estimator_events::EstimatorEvents;
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
    path: AirbornePath,
}

/// Ground truth kept for pairing: 1 s at the simulator's 50 Hz default.
const TRUTH_WINDOW: usize = 64;

impl FlightReportActor {
    /// A report of nothing yet, to be written to `out` when the run stops.
    fn new(out: PathBuf) -> FlightReportActor {
        FlightReportActor {
            out,
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
            path: AirbornePath::default(),
        }
    }

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
        self.path.on_truth(&truth);
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
        self.errors.add(nav, &truth, true_ned);
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
        self.speed_cap.on_status(status.time, status.speed_cap);
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
            tracking_error_max_m: self.tracking.max_m(),
            tracking_error_rms_m: self.tracking.rms_m(),
            path_length_m: self.path.length_m,
            straight_line_m: self.path.straight_line_m(),
            max_tilt_deg: self.path.max_tilt_deg,
            touchdown: self.path.touchdown,
        });
        FlightReport {
            mission: self.status.as_ref().map(|s| MissionSection {
                completed: s.mission.completed,
                items_reached: s.mission.reached,
                items_total: s.mission.total,
            }),
            flight,
            estimator: self.errors.section(),
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
        Ok(FlightReportActor::new(params.out.clone()))
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
    use kestrel_proto::messages::NavValidity;

    use super::super::schema::Touchdown;

    use super::*;

    const LEVEL: [f64; 4] = [1.0, 0.0, 0.0, 0.0];
    const HOME: Geodetic = Geodetic { lat_deg: 6.7971, lon_deg: 79.9017, alt_m: 20.0 };

    fn actor() -> FlightReportActor {
        FlightReportActor::new(PathBuf::from("unused.json"))
    }

    /// The truth at `us` µs, at home, airborne unless `landed`.
    fn truth(us: u64, landed: bool) -> GroundTruth {
        GroundTruth {
            time: Time::from_micros(us),
            lat_deg: HOME.lat_deg,
            lon_deg: HOME.lon_deg,
            alt_msl_m: HOME.alt_m,
            landed,
            clearance_m: Some(4.0 + us as f64 * 1e-6),
            ..Default::default()
        }
    }

    /// The estimate at `us` µs, `north_m` north of home, with home as its origin.
    fn nav(us: u64, north_m: f64) -> NavState {
        NavState {
            origin: Some(HOME),
            ..NavState::exact(Time::from_micros(us), LEVEL, [0.0; 3], [0.0; 3], [north_m, 0.0, 0.0])
        }
    }

    #[test]
    fn a_report_of_no_messages_has_every_section_null() {
        assert_eq!(actor().report(), FlightReport::default());
    }

    #[test]
    fn an_estimate_is_scored_against_the_truth_of_its_instant_even_when_it_comes_first() {
        let mut report = actor();
        report.on_truth(truth(1_000, false));
        report.on_nav(&nav(1_000, 3.0));
        // On the wall clock the estimate can come before the truth of its instant: it waits.
        report.on_nav(&nav(2_000, 1.0));
        assert_eq!(report.report().estimator.map(|e| e.samples), Some(1));
        report.on_truth(truth(2_000, false));
        let estimator = report.report().estimator.expect("scored");
        assert_eq!(estimator.samples, 2);
        assert!((estimator.rms_horizontal_m - 5.0f64.sqrt()).abs() < 1e-6, "{estimator:?}");
        assert!((estimator.max_horizontal_m - 3.0).abs() < 1e-6, "{estimator:?}");
        // Without a valid attitude an estimate is not scored.
        let mut blind = nav(3_000, 9.0);
        blind.valid = NavValidity::default();
        report.on_truth(truth(3_000, false));
        report.on_nav(&blind);
        assert_eq!(report.report().estimator.map(|e| e.samples), Some(2));
    }

    #[test]
    fn the_flight_section_comes_from_the_truth() {
        let mut report = actor();
        report.on_truth(truth(1_000_000, false));
        report.on_truth(truth(3_500_000, true));
        let flight = report.report().flight.expect("a flight section with truth");
        assert_eq!(flight.duration_s, 2.5);
        assert!(flight.landed && !flight.crashed);
        assert_eq!(flight.min_clearance_m, Some(5.0));
        assert_eq!(flight.touchdown, Some(Touchdown { speed_down_m_s: 0.0, tilt_deg: 0.0 }));
        assert_eq!((report.report().mission, report.report().estimator), (None, None));
    }
}
