//! Running a graph: build the clock and the topics from the config, start every actor under
//! its supervisor, drive lockstep time (or wait on the wall clock), and shut down cleanly on
//! the run's end or a signal (after landing an armed vehicle: [`crate::shutdown`]), flushing
//! the flight log.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use kestrel_proto::messages::{
    CommandResult, GroundTruth, SensorHealth, SupervisorEvent, VehicleCommand, VehicleStatus,
};
use kestrel_proto::{Clock, Message, Time};
use tokio_util::sync::CancellationToken;

use crate::activity::Activity;
use crate::clock::{LockstepClock, LockstepDriver, MonotonicClock};
use crate::config::{ActorDecl, ClockKind, ConfigError, LoadedConfig, Route};
use crate::fault_injection::PanicSchedule;
use crate::flight_report::{FlightReportActor, REPORT_INPUTS};
use crate::graph::Graph;
use crate::mailbox::{Doorbell, MailboxKind};
use crate::recorder::{Recorder, RecorderError, RecordingSummary};
use crate::registry::Registry;
use crate::service_manager::ServiceManager;
use crate::shutdown::{Signals, Vehicle};
use crate::supervisor::{ActorKind, EscalationHook, KindOf, Supervised, SupervisorContext};

/// How long shutdown waits for actors to stop before it closes the log anyway.
const SHUTDOWN_GRACE: Duration = Duration::from_millis(500);

/// Overrides from the command line, and hooks for embedding.
#[derive(Clone, Default)]
pub struct RunOptions {
    /// Stop after this much graph time (overrides `[run] duration_s`).
    pub duration: Option<Duration>,
    /// Lockstep pacing (overrides `[run] speedup`; 0 = as fast as possible).
    pub speedup: Option<f64>,
    /// Record to this MCAP file (overrides `[record] path`).
    pub record: Option<PathBuf>,
    /// Keep the vehicle's numbered logs in `[record] dir` when no file is recorded to. `kestrel
    /// run` does; an embedder (an in-process test flight) opts in.
    pub onboard_log: bool,
    /// Print the 1 Hz status line.
    pub status: bool,
    /// Write the flight report (JSON) here when the run ends.
    pub report: Option<PathBuf>,
    /// Called for every supervisor event about a flight-critical actor.
    pub escalate: Option<EscalationHook>,
}

/// Why a run could not start or finish.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error("{}", .0.iter().map(ToString::to_string).collect::<Vec<_>>().join("\n"))]
    Config(Vec<ConfigError>),
    #[error("flight log: {0}")]
    Recorder(#[from] RecorderError),
    #[error("cannot start the async runtime: {0}")]
    Runtime(#[source] std::io::Error),
}

/// One input route's counters at the end of a run.
#[derive(Debug, Clone)]
pub struct MailboxReport {
    /// `topic → actor.port`.
    pub route: String,
    pub kind: MailboxKind,
    pub delivered: u64,
    /// Messages a full queue refused.
    pub overflowed: u64,
    /// Unread messages a newer one replaced.
    pub conflated: u64,
}

/// What a finished run did.
#[derive(Debug)]
pub struct RunReport {
    /// Graph time when the run ended.
    pub end_time: Time,
    /// `(topic, message type, messages published)`.
    pub topics: Vec<(String, &'static str, u64)>,
    /// `(route, kind, delivered, overflowed, conflated)` for every actor input.
    pub mailboxes: Vec<MailboxReport>,
    /// Every supervisor event, in order.
    pub supervisor_events: Vec<SupervisorEvent>,
    /// The flight log, if one was written.
    pub recording: Option<RecordingSummary>,
    /// The run ended on an accepted reboot: `kestrel run` exits with
    /// [`crate::reboot::REBOOT_EXIT_CODE`].
    pub reboot: bool,
}

/// Builds every actor of `config` once into `graph`, the graph's vehicle handed on
/// ([`crate::vehicle::resolve`]): the prepared actors and every error.
fn prepare_actors(
    config: &LoadedConfig,
    registry: &Registry,
    graph: &mut Graph,
) -> (Vec<Box<dyn Supervised>>, Vec<ConfigError>) {
    let source = &config.source;
    let actors = match crate::vehicle::resolve(config) {
        Ok(actors) => actors,
        Err(e) => return (Vec::new(), vec![e.locate(source)]),
    };
    let mut errors = Vec::new();
    let mut prepared = Vec::new();
    for (name, decl) in &actors {
        let Some(kind) = registry.get(decl.kind.get_ref()) else {
            errors.push(source.error_at(
                decl.kind.span(),
                match Registry::left_out(decl.kind.get_ref()) {
                    Some(why) => {
                        format!("actor '{}' of type '{}': {why}", name.get_ref(), decl.kind.get_ref())
                    }
                    None => format!(
                        "unknown actor type '{}' for actor '{}'; known types: {}",
                        decl.kind.get_ref(),
                        name.get_ref(),
                        registry.names().join(", ")
                    ),
                },
            ));
            continue;
        };
        match kind.prepare(name.get_ref(), decl, source, graph) {
            Ok(p) => prepared.push(p),
            Err(mut e) => errors.append(&mut e),
        }
    }
    (prepared, errors)
}

/// The live parameters `config` leaves out of its ground-station link ([`Graph::unwired_parameters`]),
/// found by building every actor once on a lockstep clock without running any; actors that
/// cannot be built here (a driver without its device) count with whatever ports they declared.
pub fn unwired_parameters(config: &LoadedConfig, registry: &Registry) -> Vec<String> {
    let activity = Activity::new();
    let clock: Arc<dyn Clock> = Arc::new(LockstepClock::new(Arc::clone(&activity)));
    let mut graph = Graph::new(clock, activity);
    let _ = prepare_actors(config, registry, &mut graph);
    graph.unwired_parameters()
}

/// Who publishes and who reads each topic of `config`, found as [`unwired_parameters`] finds
/// its answer: every actor built once on a lockstep clock, none run. Drivers are built inside a
/// Tokio runtime, as in a run (a serial port registers with its reactor); `Err` when that
/// runtime cannot be made. A driver whose device is missing counts with the ports it declared
/// before it stopped.
pub fn topic_wiring(
    config: &LoadedConfig,
    registry: &Registry,
) -> std::io::Result<Vec<crate::graph::TopicWiring>> {
    let runtime = tokio::runtime::Builder::new_current_thread().enable_all().build()?;
    let _inside = runtime.enter();
    let activity = Activity::new();
    let clock: Arc<dyn Clock> = Arc::new(LockstepClock::new(Arc::clone(&activity)));
    let mut graph = Graph::new(clock, activity);
    let _ = prepare_actors(config, registry, &mut graph);
    Ok(graph.topic_wiring())
}

/// Runs the graph described by `config` until its duration passes or a signal arrives.
pub fn run(config: &LoadedConfig, registry: &Registry, options: RunOptions) -> Result<RunReport, RunError> {
    let runtime = match config.graph.run.clock {
        // One thread makes a lockstep run deterministic: tasks are polled in a fixed order.
        ClockKind::Lockstep => tokio::runtime::Builder::new_current_thread().enable_all().build(),
        ClockKind::Realtime => tokio::runtime::Builder::new_multi_thread().enable_all().build(),
    }
    .map_err(RunError::Runtime)?;
    let report = runtime.block_on(run_graph(config, registry, options));
    runtime.shutdown_timeout(SHUTDOWN_GRACE);
    report
}

async fn run_graph(
    config: &LoadedConfig,
    registry: &Registry,
    options: RunOptions,
) -> Result<RunReport, RunError> {
    config.validate().map_err(|e| RunError::Config(vec![e]))?;
    let panics = Arc::new(PanicSchedule::from_config(config).map_err(RunError::Config)?);
    if let Some(Err(m)) = options.speedup.map(crate::config::check_speedup) {
        return Err(RunError::Config(vec![config.source.error(format!("the run's {m}"))]));
    }
    let run_cfg = &config.graph.run;
    let source = &config.source;
    let activity = Activity::new();
    let lockstep = (run_cfg.clock == ClockKind::Lockstep).then(|| LockstepClock::new(Arc::clone(&activity)));
    let clock: Arc<dyn Clock> = match &lockstep {
        Some(c) => Arc::new(c.clone()),
        None => Arc::new(MonotonicClock::new()),
    };
    let mut graph = Graph::new(Arc::clone(&clock), Arc::clone(&activity));
    let events = graph
        .runtime_publisher::<SupervisorEvent>("supervisor")
        .map_err(|m| RunError::Config(vec![source.error(m)]))?;

    let (mut prepared, mut errors) = prepare_actors(config, registry, &mut graph);
    for unwired in graph.unwired_parameters() {
        tracing::warn!("{unwired}: a ground station can neither see nor tune these parameters");
    }
    if let Some(out) = &options.report {
        match flight_report_actor(out, &mut graph, source) {
            Ok(p) => prepared.push(p),
            Err(mut e) => errors.append(&mut e),
        }
    }
    if !errors.is_empty() {
        return Err(RunError::Config(errors));
    }

    let device_locks = graph.take_device_locks();
    let vehicle = vehicle_handles(&mut graph).map_err(|m| RunError::Config(vec![source.error(m)]))?;
    let alive = graph.observe::<VehicleStatus>("vehicle_status", Doorbell::new());
    let reboot_watch = {
        let doorbell = Doorbell::new();
        graph
            .observe_as::<CommandResult>("command_result", MailboxKind::Queue(64), Arc::clone(&doorbell))
            .map(|results| crate::reboot::RebootWatch { results, doorbell })
    };
    let record_path = options.record.clone().or_else(|| config.graph.record.path.clone());
    // One file when one is named; else the vehicle's numbered logs when a log directory is set.
    let (recorder, onboard_status) = match record_path.as_deref() {
        Some(path) => (Some(Recorder::create(path)?), None),
        None if !options.onboard_log => (None, None),
        None => match config.graph.record.onboard().map_err(|m| RunError::Config(vec![source.error(m)]))? {
            Some(onboard) => {
                check_status_recorded(config).map_err(|m| RunError::Config(vec![source.error(m)]))?;
                let (recorder, status) = Recorder::onboard(onboard)?;
                (Some(recorder), Some(status))
            }
            None => (None, None),
        },
    };
    // A write error is reported at once on `sensor_health` (src/recorder/write_watch.rs). The
    // runtime is a publisher of that topic whenever something reads it, recorder or not, so a
    // graph that routes it to the link (config/sim.toml) also builds with recording off
    // (tests/config_bench.rs `every_config_builds_or_names_the_hardware_it_lacks`).
    let reads_health = graph.is_subscribed("sensor_health", SensorHealth::TYPE_NAME);
    let health = if recorder.is_some() || reads_health {
        Some(
            graph
                .runtime_publisher::<SensorHealth>("sensor_health")
                .map_err(|m| RunError::Config(vec![source.error(m)]))?,
        )
    } else {
        None
    };
    let write_watch = recorder.as_ref().zip(health).map(|(r, health)| (r.failure_probe(), health));
    let truth = graph.observe::<GroundTruth>("ground_truth", Doorbell::new());
    let commander = graph.observe::<VehicleStatus>("vehicle_status", Doorbell::new());
    let topics = graph
        .finish(source, recorder.as_ref().map(|r| (r, config.graph.record.topics.as_slice())))
        .map_err(|e| RunError::Config(vec![e]))?;
    let mailboxes = graph.mailboxes();

    let shutdown = CancellationToken::new();
    let log = Arc::new(Mutex::new(Vec::new()));
    let supervisor_ctx = SupervisorContext {
        clock: Arc::clone(&clock),
        activity: Arc::clone(&activity),
        shutdown: shutdown.clone(),
        events,
        escalate: options.escalate.clone().unwrap_or_else(|| {
            Arc::new(|e: &SupervisorEvent| {
                tracing::error!(actor = %e.actor, kind = ?e.kind, reason = %e.reason, "flight-critical actor failed")
            })
        }),
        log: Arc::clone(&log),
        panics,
        dedicated_threads: config.graph.run.clock == ClockKind::Realtime,
    };
    let signals = Signals::install();
    let service = ServiceManager::from_env();
    let supervisors: Vec<_> = prepared.into_iter().map(|p| p.spawn(supervisor_ctx.clone())).collect();
    tokio::spawn(crate::shutdown::on_signals(
        signals,
        vehicle,
        Arc::clone(&clock),
        lockstep.is_some(),
        service.clone(),
        shutdown.clone(),
    ));
    let reboot = Arc::new(AtomicBool::new(false));
    if let Some(watch) = reboot_watch {
        tokio::spawn(crate::reboot::on_reboot(watch, Arc::clone(&reboot), shutdown.clone()));
    }
    service.ready(&format!("running {}", source.path.display()));
    tokio::spawn(service.clone().feed_watchdog(alive, shutdown.clone()));
    if options.status && run_cfg.status_period_s > 0.0 {
        tokio::spawn(crate::status::run(
            Duration::from_secs_f64(run_cfg.status_period_s),
            Arc::clone(&clock),
            topics.clone(),
            truth,
            commander,
            onboard_status.clone(),
            shutdown.clone(),
        ));
    }

    if let Some((probe, health)) = write_watch {
        tokio::spawn(crate::recorder::write_watch::run(probe, Arc::clone(&clock), health, shutdown.clone()));
    }

    let duration = options.duration.or(run_cfg.duration_s.map(Duration::from_secs_f64));
    let end = duration.map(|d| Time::ZERO + d);
    match lockstep {
        Some(lockstep) => {
            let speedup = options.speedup.unwrap_or(run_cfg.speedup);
            let pace = (speedup > 0.0).then_some(speedup);
            LockstepDriver::new(lockstep, Arc::clone(&activity), pace, end).run(shutdown.clone()).await;
        }
        None => {
            tokio::select! {
                _ = shutdown.cancelled() => {}
                _ = async { match end { Some(end) => clock.sleep_until(end).await, None => std::future::pending().await } } => {}
            }
            shutdown.cancel();
        }
    }
    let stopped = async {
        for s in supervisors {
            let _ = s.await;
        }
    };
    if tokio::time::timeout(SHUTDOWN_GRACE, stopped).await.is_err() {
        tracing::warn!("some actors did not stop within {SHUTDOWN_GRACE:?}; closing the log anyway");
    }
    service.stopping();
    drop(device_locks);
    let end_time = clock.now();
    let recording = recorder.map(Recorder::finish).transpose()?;
    if let Some(error) =
        onboard_status.and_then(|s| s.lock().unwrap_or_else(|e| e.into_inner()).last_error.clone())
    {
        tracing::error!("the vehicle's log: {error}");
    }
    let supervisor_events = log.lock().unwrap_or_else(|e| e.into_inner()).clone();
    Ok(RunReport {
        end_time,
        topics: topics.iter().map(|t| (t.name.clone(), t.type_name, t.published())).collect(),
        mailboxes: mailboxes
            .iter()
            .map(|m| {
                let s = m.stats();
                MailboxReport {
                    route: m.label().to_owned(),
                    kind: m.kind(),
                    delivered: s.delivered.load(Ordering::Relaxed),
                    overflowed: s.overflowed.load(Ordering::Relaxed),
                    conflated: s.conflated.load(Ordering::Relaxed),
                }
            })
            .collect(),
        supervisor_events,
        recording,
        reboot: reboot.load(Ordering::SeqCst),
    })
}

/// Per-flight logs start and end on the recorded `vehicle_status`: it must be among the
/// recorded topics unless one log covers the whole run.
fn check_status_recorded(config: &LoadedConfig) -> Result<(), String> {
    let record = &config.graph.record;
    let status = crate::recorder::onboard::STATUS_TOPIC;
    if record.log_disarmed || record.topics.iter().any(|t| t.get_ref() == "*" || t.get_ref() == status) {
        return Ok(());
    }
    Err(format!(
        "[record] dir needs '{status}' among the recorded topics (it starts and ends each log), or log_disarmed = true"
    ))
}

/// The report actor, subscribed to whichever of its topics this graph publishes.
fn flight_report_actor(
    out: &std::path::Path,
    graph: &mut Graph,
    source: &crate::config::Source,
) -> Result<Box<dyn crate::supervisor::Supervised>, Vec<ConfigError>> {
    use toml::Spanned;
    let nowhere = |s: &str| Spanned::new(0..0, s.to_owned());
    let mut params = toml::Table::new();
    params.insert("out".into(), toml::Value::String(out.display().to_string()));
    let inputs = REPORT_INPUTS
        .iter()
        .filter(|(topic, type_name)| graph.is_published(topic, type_name))
        .map(|(topic, _)| (nowhere(topic), Route { topic: nowhere(topic), mailbox: nowhere("queue(65536)") }))
        .collect();
    let decl = ActorDecl {
        kind: nowhere("flight_report"),
        critical: false,
        priority: None,
        restart: Default::default(),
        params: Some(Spanned::new(0..0, params)),
        inputs,
        outputs: Default::default(),
    };
    KindOf::<FlightReportActor>::default().prepare("flight_report", &decl, source, graph)
}

/// What the shutdown path needs when the graph has a commander: its status (observed) and a
/// publisher on the topic it takes commands from.
fn vehicle_handles(graph: &mut Graph) -> Result<Option<Vehicle>, String> {
    if !graph.is_subscribed("vehicle_command", VehicleCommand::TYPE_NAME) {
        return Ok(None);
    }
    let doorbell = Doorbell::new();
    let Some(status) = graph.observe::<VehicleStatus>("vehicle_status", Arc::clone(&doorbell)) else {
        return Ok(None);
    };
    let command = graph.runtime_publisher::<VehicleCommand>("vehicle_command")?;
    Ok(Some(Vehicle { status, doorbell, command }))
}
