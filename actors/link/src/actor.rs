//! The link actor: the graph's side of MAVLink. Inputs update what telemetry reports, timers
//! drive the heartbeat and the stream scheduler, and the endpoint tasks spawned in `start` carry
//! frames in and out until shutdown.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use kestrel_proto::messages::{
    ActuatorOutputs, AvoidanceCommand, BaroSample, BatteryStatus, CalibrationCommand, CalibrationEvent,
    CommandResult, DepthGrid, EscPulses, EstimatorStatus, FailureInjection, FailureInjectionResult,
    FencePlan, GpsFix, GroundTruth, ImuSample, ManualControl, Mission, NavState, ParamDecl, ParamSet,
    RallyPoints, RangefinderSample, SensorHealth, Setpoint, VehicleCommand, VehicleStatus,
};
use kestrel_proto::{Actor, ActorError, Clock, Context, Publisher, Setup, Time};

use crate::config::{EndpointKind, LinkParams};
use crate::hub::Hub;
use crate::services::ToGraph;
use crate::services::events::statustext;
use crate::services::mission::PlanStore;
use crate::services::params::{ParamTable, parse_param_file};
use crate::transport::{
    GraphSink, OpenEndpoint, ParamWriter, Shared, file_writer, open_all, param_writer_for,
};
use crate::vehicle::Vehicle;
use mavlink::dialects::ardupilotmega::MavSeverity;

/// Period of the scheduler that sends telemetry and checks timeouts (50 Hz: the fastest stream
/// rate we honour).
pub const TICK_PERIOD: Duration = Duration::from_millis(20);

/// Everything the link actor handles.
#[derive(Debug)]
pub enum LinkInput {
    Nav(NavState),
    Gps(GpsFix),
    Battery(BatteryStatus),
    Status(VehicleStatus),
    /// The commander's answer to a command (port `command_result`): its COMMAND_ACK.
    CommandResult(CommandResult),
    /// The estimator's innovations and health (port `estimator_status`; optional): the test
    /// ratios in EKF_STATUS_REPORT.
    Estimator(Box<EstimatorStatus>),
    Depth(DepthGrid),
    /// A rangefinder's sample (ports `rangefinder_up`, `rangefinder_down`; optional), sent as
    /// DISTANCE_SENSOR; the sample's own orientation says which sensor it is.
    Rangefinder(RangefinderSample),
    /// The obstacle avoider's newest correction (port `avoidance`), sent as DEBUG_VECT.
    Avoidance(AvoidanceCommand),
    /// The IMU's newest sample (port `imu`; optional, `latest`): RAW_IMU, SCALED_IMU, HIGHRES_IMU.
    Imu(ImuSample),
    /// The barometer's newest sample (port `baro`; optional): SCALED_PRESSURE.
    Baro(BaroSample),
    /// The mixer's newest motor outputs (port `actuator_outputs`; optional): SERVO_OUTPUT_RAW.
    Actuators(ActuatorOutputs),
    /// Pulses driven directly while disarmed (port `esc_pulses`; optional, `latest`): a motor
    /// test's or an ESC calibration's, shown in SERVO_OUTPUT_RAW while they are obeyed.
    EscPulses(EscPulses),
    /// The commander's newest setpoint (port `setpoint`; optional, `latest`):
    /// POSITION_TARGET_LOCAL_NED, POSITION_TARGET_GLOBAL_INT, NAV_CONTROLLER_OUTPUT.
    Setpoint(Setpoint),
    /// The newest sticks on the graph (port `sticks`, topic `manual_control`; optional): the RC
    /// receiver's or a ground station's, for RC_CHANNELS.
    Sticks(ManualControl),
    /// A driver's health report (port `sensor_health`; hardware graphs): errors become a
    /// STATUSTEXT warning.
    SensorHealth(SensorHealth),
    /// The simulator's ground truth (port `ground_truth`; simulated graphs only), sent as
    /// SIMSTATE as ArduPilot SITL does, so a ground station can judge the estimate.
    Truth(Box<GroundTruth>),
    /// An actor's live parameters (port `param_decl`).
    ParamDecl(ParamDecl),
    /// The calibration's answers, progress and results (port `calibration_event`).
    Calibration(CalibrationEvent),
    /// The injector's answer to a MAV_CMD_INJECT_FAILURE (port `failure_result`).
    FailureResult(FailureInjectionResult),
    Heartbeat(Time),
    Tick(Time),
}

/// The link's outputs into the graph.
#[derive(Clone)]
pub struct LinkOutputs {
    pub command: Publisher<VehicleCommand>,
    pub mission: Publisher<Mission>,
    pub fence: Publisher<FencePlan>,
    /// Rally points uploaded or cleared (port `rally`): where RTL may return instead of home.
    pub rally: Publisher<RallyPoints>,
    pub manual: Publisher<ManualControl>,
    pub param: Publisher<ParamSet>,
    pub calibration: Publisher<CalibrationCommand>,
    pub inject_failure: Publisher<FailureInjection>,
}

impl LinkOutputs {
    /// Publishes `out`, stamping commands with `now`.
    pub fn publish(&self, out: Vec<ToGraph>, now: Time) {
        for o in out {
            match o {
                ToGraph::Command(command) => {
                    self.command.publish(VehicleCommand { id: 0, time: now, command })
                }
                ToGraph::Request { id, command } => {
                    self.command.publish(VehicleCommand { id, time: now, command })
                }
                ToGraph::Mission(m) => self.mission.publish(m),
                ToGraph::Fence(f) => self.fence.publish(f),
                ToGraph::Rally(r) => self.rally.publish(r),
                ToGraph::Manual(m) => self.manual.publish(m),
                ToGraph::Param(p) => self.param.publish(p),
                ToGraph::Calibration { id, request } => {
                    self.calibration.publish(CalibrationCommand { time: now, id, request })
                }
                ToGraph::InjectFailure(f) => self.inject_failure.publish(f),
            }
        }
    }
}

/// The MAVLink link actor (config type name: `link`).
pub struct LinkActor {
    params: LinkParams,
    config_dir: PathBuf,
    hub: Arc<Mutex<Hub>>,
    outputs: LinkOutputs,
    clock: Arc<dyn Clock>,
    endpoints: Vec<OpenEndpoint>,
    /// Persists parameter changes on its own thread; finished (pending text written) in `stop`.
    param_writer: Option<Arc<ParamWriter>>,
    /// The plans restored from the state directory, published in `start`, and what was not.
    restored: Restored,
}

impl LinkActor {
    /// The endpoints opened by `start` (with their bound addresses).
    pub fn endpoints(&self) -> &[OpenEndpoint] {
        &self.endpoints
    }

    fn hub(&self) -> std::sync::MutexGuard<'_, Hub> {
        self.hub.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// The file changed parameters persist in: `param_file` (relative to the config directory),
/// else `params.parm` in the state directory, else none.
pub fn param_path(params: &LinkParams, config_dir: &std::path::Path) -> Option<PathBuf> {
    match (&params.param_file, &params.state_dir) {
        (Some(file), _) => Some(config_dir.join(file)),
        (None, Some(dir)) => Some(config_dir.join(dir).join(PARAM_FILE)),
        (None, None) => None,
    }
}

/// Name of the parameter file in the state directory (ArduPilot's `.parm` form: NAME=VALUE).
pub const PARAM_FILE: &str = "params.parm";

/// Builds the parameter table from the config's own entries and the persisted file (if any);
/// the graph's actors add theirs as their declarations arrive. A file with a line that does not
/// read restores nothing (a vehicle starts on its defaults rather than on part of a file): the
/// second value says why, naming the file and the line.
pub fn load_params(
    params: &LinkParams,
    config_dir: &std::path::Path,
) -> Result<(ParamTable, Option<String>), ActorError> {
    let mut table = ParamTable::new(params.params.clone()).map_err(|e| ActorError::Params(e.to_string()))?;
    let Some(path) = param_path(params, config_dir) else { return Ok((table, None)) };
    match std::fs::read_to_string(&path) {
        Ok(text) => {
            let (pairs, bad) = parse_param_file(&text);
            if let Some(line) = bad.first() {
                let n = text.lines().position(|l| l.trim() == line).map_or(0, |i| i + 1);
                let why =
                    format!("{}:{n}: \"{line}\" is not NAME=VALUE; no parameter restored", path.display());
                tracing::error!("{why}");
                return Ok((table, Some(why)));
            }
            for (name, value) in pairs {
                if let Err(e) = table.restore(&name, value) {
                    tracing::warn!(path = %path.display(), error = %e, "stored parameter ignored");
                }
            }
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(source) => {
            return Err(ActorError::Io { what: format!("parameter file {}", path.display()), source });
        }
    }
    Ok((table, None))
}

/// The end of an error about a stored file that a STATUSTEXT can hold: from the file's own name.
fn short(error: &str) -> &str {
    error.rfind('/').map_or(error, |i| &error[i + 1..])
}

/// What a restart restored: the plans for the graph, and what could not be restored (said as
/// STATUSTEXT once the endpoints are open).
#[derive(Default)]
struct Restored {
    graph: Vec<ToGraph>,
    errors: Vec<String>,
}

impl Actor for LinkActor {
    type Params = LinkParams;
    type Input = LinkInput;

    fn build(params: &LinkParams, setup: &mut impl Setup<LinkInput>) -> Result<Self, ActorError> {
        let params = &params.for_instance().map_err(ActorError::Params)?;
        if params.system_id == 0 {
            return Err(ActorError::Params("system_id must be 1..=255".into()));
        }
        let gcs_timeout =
            kestrel_proto::timing::positive_seconds("gcs_timeout_s", params.gcs_timeout_s, 3600.0)?;
        let config_dir = setup.config_dir().to_owned();
        let (table, param_error) = load_params(params, &config_dir)?;
        for endpoint in &params.endpoints {
            if let EndpointKind::Serial { device, .. } = &endpoint.kind {
                setup.claim_device(device)?;
            }
        }
        setup.input("nav_state", LinkInput::Nav);
        setup.input("gps", LinkInput::Gps);
        setup.input("battery", LinkInput::Battery);
        setup.input("vehicle_status", LinkInput::Status);
        setup.input("command_result", LinkInput::CommandResult);
        setup.input("estimator_status", |s| LinkInput::Estimator(Box::new(s)));
        setup.input("depth_grid", LinkInput::Depth);
        setup.input("avoidance", LinkInput::Avoidance);
        setup.input("imu", LinkInput::Imu);
        setup.input("baro", LinkInput::Baro);
        setup.input("actuator_outputs", LinkInput::Actuators);
        setup.input("esc_pulses", LinkInput::EscPulses);
        setup.input("setpoint", LinkInput::Setpoint);
        setup.input("sticks", LinkInput::Sticks);
        setup.input("rangefinder_up", LinkInput::Rangefinder);
        setup.input("rangefinder_down", LinkInput::Rangefinder);
        setup.input("ground_truth", |t| LinkInput::Truth(Box::new(t)));
        setup.input("sensor_health", LinkInput::SensorHealth);
        setup.input("param_decl", LinkInput::ParamDecl);
        setup.input("calibration_event", LinkInput::Calibration);
        setup.input("failure_result", LinkInput::FailureResult);
        setup.timer("heartbeat", Duration::from_secs(1), LinkInput::Heartbeat);
        setup.timer("tick", TICK_PERIOD, LinkInput::Tick);
        let outputs = LinkOutputs {
            command: setup.output("vehicle_command"),
            mission: setup.output("mission"),
            fence: setup.output("fence"),
            rally: setup.output("rally"),
            manual: setup.output("manual_control"),
            param: setup.output("param_set"),
            calibration: setup.output("calibration_command"),
            inject_failure: setup.output("inject_failure"),
        };
        let mut vehicle = Vehicle::new(params.system_id, table, gcs_timeout);
        vehicle.serve_logs(params.log_dir.clone().map(crate::services::log_download::LogDirectory::new));
        let mut restored = Restored { graph: Vec::new(), errors: param_error.into_iter().collect() };
        if let Some(dir) = &params.state_dir {
            let dir = config_dir.join(dir);
            let store = PlanStore::open(&dir).map_err(|source| ActorError::Io {
                what: format!("state directory {}", dir.display()),
                source,
            })?;
            let (graph, errors) = vehicle.keep_plans_in(store, setup.clock().now());
            for e in &errors {
                tracing::error!("{e}; not restored");
            }
            restored.graph = graph;
            restored.errors.extend(errors);
        }
        Ok(LinkActor {
            params: params.clone(),
            config_dir,
            hub: Arc::new(Mutex::new(Hub::new(vehicle))),
            outputs,
            clock: setup.clock(),
            endpoints: Vec::new(),
            param_writer: None,
            restored,
        })
    }

    async fn start(&mut self, ctx: &Context) -> Result<(), ActorError> {
        let outputs = self.outputs.clone();
        let clock = Arc::clone(&self.clock);
        let graph: GraphSink = Arc::new(move |out| outputs.publish(out, clock.now()));
        if let Some(path) = param_path(&self.params, &self.config_dir) {
            let write = file_writer(path.clone());
            let writer = param_writer_for(&self.hub, Arc::clone(&graph), Arc::clone(&self.clock), write)
                .map_err(|source| ActorError::Io {
                    what: format!("parameter writer thread for {}", path.display()),
                    source,
                })?;
            self.param_writer = Some(Arc::new(writer));
        }
        let shared = Shared {
            hub: Arc::clone(&self.hub),
            clock: Arc::clone(&self.clock),
            shutdown: ctx.shutdown().clone(),
            graph,
            param_writer: self.param_writer.clone(),
            endpoint: 0,
        };
        self.endpoints = open_all(&self.params.endpoints, &self.config_dir, &shared)
            .await
            .map_err(|e| ActorError::Failed(e.to_string()))?;
        for e in &self.endpoints {
            tracing::info!(endpoint = %e.name, local = ?e.local_addr, "MAVLink endpoint open");
        }
        let restored = std::mem::take(&mut self.restored);
        self.outputs.publish(restored.graph, self.clock.now());
        if !restored.errors.is_empty() {
            // The whole text is in the log; a STATUSTEXT holds 50 characters: the file's name
            // and line.
            let mav = restored
                .errors
                .iter()
                .map(|e| statustext(MavSeverity::MAV_SEVERITY_ERROR, short(e)))
                .collect();
            let mut hub = self.hub();
            let _ = hub.dispatch(crate::services::Outputs { mav, graph: Vec::new() });
        }
        Ok(())
    }

    async fn handle(&mut self, _ctx: &Context, input: LinkInput) -> Result<(), ActorError> {
        let out = {
            let mut hub = self.hub();
            match input {
                LinkInput::Nav(n) => {
                    hub.vehicle().on_nav(n);
                    Vec::new()
                }
                LinkInput::Gps(g) => {
                    hub.vehicle().on_gps(g);
                    Vec::new()
                }
                LinkInput::Estimator(s) => {
                    let out = hub.vehicle().on_estimator(*s);
                    hub.dispatch(out)
                }
                LinkInput::Battery(b) => {
                    hub.vehicle().on_battery(b);
                    Vec::new()
                }
                LinkInput::Depth(d) => {
                    hub.vehicle().on_depth(d);
                    Vec::new()
                }
                LinkInput::Avoidance(a) => {
                    hub.vehicle().on_avoidance(a);
                    Vec::new()
                }
                LinkInput::Imu(imu) => {
                    hub.vehicle().on_imu(imu);
                    Vec::new()
                }
                LinkInput::Baro(baro) => {
                    hub.vehicle().on_baro(baro);
                    Vec::new()
                }
                LinkInput::Actuators(actuators) => {
                    hub.vehicle().on_actuators(actuators);
                    Vec::new()
                }
                LinkInput::EscPulses(pulses) => {
                    hub.vehicle().on_esc_pulses(pulses);
                    Vec::new()
                }
                LinkInput::Setpoint(setpoint) => {
                    hub.vehicle().on_setpoint(setpoint);
                    Vec::new()
                }
                LinkInput::Sticks(sticks) => {
                    hub.vehicle().on_sticks(sticks);
                    Vec::new()
                }
                LinkInput::Rangefinder(r) => {
                    hub.vehicle().on_rangefinder(r);
                    Vec::new()
                }
                LinkInput::SensorHealth(h) => {
                    let out = hub.vehicle().on_sensor_health(&h);
                    hub.dispatch(out)
                }
                LinkInput::Truth(t) => {
                    hub.vehicle().on_truth(*t);
                    Vec::new()
                }
                LinkInput::Status(s) => {
                    let out = hub.vehicle().on_status(s);
                    hub.dispatch(out)
                }
                LinkInput::CommandResult(r) => {
                    let out = hub.vehicle().on_command_result(&r);
                    hub.dispatch(out)
                }
                LinkInput::ParamDecl(d) => {
                    let out = hub.vehicle().on_param_decl(&d, d.time);
                    if let Some(writer) = &self.param_writer
                        && let Some(write) = hub.vehicle().take_param_write()
                    {
                        writer.submit_tagged(write.batch, write.text);
                    }
                    hub.dispatch(out)
                }
                LinkInput::Calibration(e) => {
                    let out = hub.vehicle().on_calibration(&e);
                    hub.dispatch(out)
                }
                LinkInput::FailureResult(r) => {
                    let out = hub.vehicle().on_injection_result(&r);
                    hub.dispatch(out)
                }
                LinkInput::Heartbeat(_) => {
                    hub.send_heartbeat();
                    Vec::new()
                }
                LinkInput::Tick(t) => hub.on_tick(t),
            }
        };
        if !out.is_empty() {
            self.outputs.publish(out, self.clock.now());
        }
        Ok(())
    }

    async fn stop(&mut self, _ctx: &Context) {
        self.hub().vehicle().finish_plans();
        if let Some(writer) = self.param_writer.take() {
            let finished = tokio::task::spawn_blocking(move || {
                writer.finish();
                writer.stats()
            })
            .await;
            match finished {
                Ok(stats) => tracing::info!(?stats, "parameter file writer finished"),
                Err(e) => tracing::error!(error = %e, "parameter file writer did not finish"),
            }
        }
        let mut hub = self.hub();
        // A last HEARTBEAT with the final state: a run that ends itself (`--exit-on-land` at
        // the disarm) would otherwise leave ground stations showing the vehicle armed.
        hub.send_heartbeat();
        for (name, stats) in hub.link_stats() {
            tracing::info!(link = %name, ?stats, "MAVLink link counters");
        }
        tracing::info!(stats = ?hub.stats(), "MAVLink hub counters");
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::config::{ParamKind, ParamSpec};
    use crate::transport::write_atomically;

    #[test]
    fn persisted_parameters_come_back_after_a_restart_and_a_bad_line_restores_none() {
        let dir = std::env::temp_dir().join(format!("kestrel-link-params-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        write_atomically(&dir.join("p.txt"), "RTL_ALT_M=55\nRTL_ALT_M_X=1\n").expect("write");
        write_atomically(&dir.join("bad.txt"), "RTL_ALT_M=55\n# a comment\nRTL_ALT_M=oops\n").expect("write");
        let params = LinkParams {
            params: vec![ParamSpec {
                name: "RTL_ALT_M".into(),
                value: 30.0,
                min: 5.0,
                max: 120.0,
                kind: ParamKind::Real32,
                unit: "m".into(),
            }],
            param_file: Some("p.txt".into()),
            ..LinkParams::default()
        };
        let (table, error) = load_params(&params, &dir).expect("loads");
        assert_eq!((table.values().collect::<Vec<_>>(), error), (vec![("RTL_ALT_M", 55.0)], None));
        let bad = LinkParams { param_file: Some("bad.txt".into()), ..params.clone() };
        let (table, error) = load_params(&bad, &dir).expect("loads");
        assert_eq!(table.values().collect::<Vec<_>>(), [("RTL_ALT_M", 30.0)], "nothing restored");
        let error = error.expect("an error");
        assert!(error.contains("bad.txt:3: \"RTL_ALT_M=oops\""), "{error}");
        let missing = LinkParams { param_file: Some("absent.txt".into()), ..params.clone() };
        assert_eq!(
            load_params(&missing, &dir).expect("no file yet").0.values().next(),
            Some(("RTL_ALT_M", 30.0))
        );
        // With a state directory and no param_file, the parameters live there.
        let state = LinkParams { param_file: None, state_dir: Some(dir.clone()), ..params };
        assert_eq!(param_path(&state, Path::new("/elsewhere")), Some(dir.join(PARAM_FILE)));
        std::fs::remove_dir_all(&dir).ok();
    }
}
