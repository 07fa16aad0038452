//! The vehicle as a MAVLink component (sysid from config, compid 1): dispatches decoded messages
//! addressed to us to the microservices and gathers their answers. Synchronous and I/O-free.
#![allow(
    deprecated,
    reason = "legacy MAVLink (MISSION_ITEM, REQUEST_DATA_STREAM, SET_MODE, *_INT frames) is still spoken by ground stations and must be accepted"
)]

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::messages::{
    ActuatorOutputs, AvoidanceCommand, BaroSample, BatteryStatus, CalibrationEvent, CalibrationUpdate,
    Command, CommandResult, DepthGrid, EscPulses, EstimatorStatus, FAILURE_INJECTION_ENABLE,
    FailureInjectionResult, FlightMode, GpsFix, GroundTruth, ImuSample, NavState, ParamDecl,
    RangefinderSample, SensorHealth, VehicleStatus,
};
use mavlink::dialects::ardupilotmega::{
    AUTOPILOT_VERSION_DATA, COMMAND_ACK_DATA, COMMAND_INT_DATA, COMMAND_LONG_DATA, HOME_POSITION_DATA,
    MISSION_CURRENT_DATA, MISSION_ITEM_REACHED_DATA, MavMessage, MavProtocolCapability, MavSeverity, MavType,
};
use mavlink::{Message, MessageData};

use crate::frame::Frame;
use crate::services::command::{self, CommandRequest, CommandService};
use crate::services::events::{status_changes, statustext};
use crate::services::follow;
use crate::services::ftp::FtpServer;
use crate::services::heartbeat::{GcsEvent, GcsWatch, vehicle_heartbeat};
use crate::services::log_download::{LogDirectory, LogDownload};
use crate::services::mission::MissionService;
use crate::services::offboard::{
    OffboardRejects, attitude_target, global_target, local_target, manual_control,
};
use crate::services::params::{ParamTable, ParamWrite};
use crate::services::sensor_health::HealthAnnouncer;
use crate::services::telemetry::{Telemetry, home};
use crate::services::{Outputs, Sender, Service, ToGraph};
use crate::services::{calibration, estimator_text, timesync};
use crate::station::{EndpointIndex, Station, StationOut};

/// Our component id (MAV_COMP_ID_AUTOPILOT1).
pub const COMPONENT_ID: u8 = 1;

/// The parameter naming the ground station in control (ArduPilot 4.7's name for SYSID_MYGCS),
/// declared by the commander, and its default there and in ArduPilot.
const GCS_SYSID_PARAM: &str = "MAV_GCS_SYSID";
const DEFAULT_GCS_SYSID: u8 = 255;

/// What we claim in AUTOPILOT_VERSION: only what this crate implements (FTP is read-only: the
/// logs and `@PARAM/param.pck`, see `services::ftp`). Rally points: uploaded, downloaded and
/// flown to by RTL (the commander's `rally`).
pub fn capabilities() -> MavProtocolCapability {
    MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_INT
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_COMMAND_INT
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MAVLINK2
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_FTP
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_RALLY
}

/// The vehicle's side of every microservice.
#[derive(Debug)]
pub struct Vehicle {
    system_id: u8,
    commands: CommandService,
    params: ParamTable,
    missions: MissionService,
    telemetry: Telemetry,
    gcs: GcsWatch,
    /// Refused MANUAL_CONTROL / SET_POSITION_TARGET_* input.
    pub offboard_rejects: OffboardRejects,
    /// Messages addressed to us that we could not use (wrong shape, unknown command id).
    pub unhandled: u64,
    /// The last id of a STATUSTEXT sent in chunks.
    text_id: u16,
    /// Which health reports are said (`services/sensor_health.rs`).
    health: HealthAnnouncer,
    /// A ground station's COMMAND_ACK confirming an accelerometer calibration position.
    accelcal: calibration::AccelcalSnoop,
    logs: LogDownload,
    ftp: FtpServer,
}

impl Vehicle {
    /// A vehicle with system id `system_id` and the given parameters.
    pub fn new(system_id: u8, params: ParamTable, gcs_timeout: Duration) -> Vehicle {
        Vehicle {
            system_id,
            commands: CommandService::new(),
            params,
            missions: MissionService::new(),
            telemetry: Telemetry::new(),
            gcs: GcsWatch::new(gcs_timeout),
            offboard_rejects: OffboardRejects::default(),
            unhandled: 0,
            text_id: 0,
            health: HealthAnnouncer::default(),
            accelcal: calibration::AccelcalSnoop::default(),
            logs: LogDownload::new(None),
            ftp: FtpServer::new(None),
        }
    }

    /// Serve the logs of `dir` by log download and FTP (`None`: serve none).
    pub fn serve_logs(&mut self, dir: Option<LogDirectory>) {
        self.logs = LogDownload::new(dir.clone());
        self.ftp = FtpServer::new(dir);
    }

    /// Our system id.
    pub fn system_id(&self) -> u8 {
        self.system_id
    }

    /// The parameter table (for persisting).
    pub fn params(&self) -> &ParamTable {
        &self.params
    }

    /// An actor declared its live parameters (topic `param_decl`): they join the table, and
    /// values set earlier go back to the owner as `ParamSet`.
    pub fn on_param_decl(&mut self, decl: &ParamDecl, now: Time) -> Outputs {
        self.params.declare(decl, now).out
    }

    /// Keeps the uploaded plans in `store` from now on and restores the ones it holds: what the
    /// graph must be told, and why a plan was not restored (`MissionService::keep_in`).
    pub fn keep_plans_in(
        &mut self,
        store: crate::services::mission::PlanStore,
        now: Time,
    ) -> (Vec<ToGraph>, Vec<String>) {
        self.missions.keep_in(store, now)
    }

    /// Writes the plans still pending to disk (at shutdown).
    pub fn finish_plans(&self) {
        self.missions.finish_store();
    }

    /// The parameter file text to write after a change, once per change.
    pub fn take_param_write(&mut self) -> Option<ParamWrite> {
        self.params.take_write()
    }

    /// Echo parameter sets only once the parameter file holds them (the link has one).
    pub fn hold_param_echoes_until_saved(&mut self) {
        self.params.hold_echoes_until_saved();
    }

    /// The parameter file write `batch` ended: held echoes, or the old values put back.
    pub fn on_params_saved(&mut self, batch: u64, result: Result<(), &str>, now: Time) -> Outputs {
        self.params.on_saved(batch, result, now)
    }

    /// Whether `msg` is for us: no target, broadcast, or our system (and component 0 or ours).
    pub fn is_for_us(&self, msg: &MavMessage) -> bool {
        let sys_ok = msg.target_system_id().is_none_or(|t| t == 0 || t == self.system_id);
        let comp_ok = msg.target_component_id().is_none_or(|c| c == 0 || c == COMPONENT_ID);
        sys_ok && comp_ok
    }

    /// The ground station in control: the commander's `MAV_GCS_SYSID` once it is declared,
    /// ArduPilot's default 255 until then.
    fn gcs_system_id(&self) -> u8 {
        self.params
            .values()
            .find(|(name, _)| *name == GCS_SYSID_PARAM)
            .and_then(|(_, v)| (v.fract() == 0.0 && (1.0..=255.0).contains(&v)).then_some(v as u8))
            .unwrap_or(DEFAULT_GCS_SYSID)
    }

    /// Our HEARTBEAT.
    pub fn heartbeat(&self) -> MavMessage {
        MavMessage::HEARTBEAT(vehicle_heartbeat(self.telemetry.snapshot.status.as_ref()))
    }

    /// AUTOPILOT_VERSION.
    pub fn autopilot_version(&self) -> MavMessage {
        let v = |s: &str| s.parse::<u32>().unwrap_or(0);
        let version = (v(env!("CARGO_PKG_VERSION_MAJOR")) << 24)
            | (v(env!("CARGO_PKG_VERSION_MINOR")) << 16)
            | (v(env!("CARGO_PKG_VERSION_PATCH")) << 8);
        MavMessage::AUTOPILOT_VERSION(AUTOPILOT_VERSION_DATA {
            capabilities: capabilities(),
            uid: u64::from(self.system_id),
            flight_sw_version: version,
            ..Default::default()
        })
    }

    /// Handles a message from `from` (already known to be for us).
    pub fn on_message(&mut self, from: Sender, msg: &MavMessage, now: Time) -> Outputs {
        let services: [&mut dyn Service; 3] = [&mut self.params, &mut self.missions, &mut self.logs];
        for service in services {
            if let Some(out) = service.on_message(from, msg, now) {
                return out;
            }
        }
        match msg {
            MavMessage::HEARTBEAT(hb) if hb.mavtype == MavType::MAV_TYPE_GCS => {
                // Every ground station's heartbeat goes to the commander, which keeps the data
                // link only on `MAV_GCS_SYSID`'s; the link's own lost/regained texts follow
                // the same one.
                let system_id = from.target_system();
                let command = Command::Heartbeat { system_id };
                let mut out = Outputs { mav: Vec::new(), graph: vec![ToGraph::Command(command)] };
                if system_id == self.gcs_system_id() && self.gcs.heard(now) == Some(GcsEvent::Regained) {
                    out.mav.push(statustext(MavSeverity::MAV_SEVERITY_INFO, "GCS link regained"));
                }
                out
            }
            MavMessage::HEARTBEAT(_) | MavMessage::RADIO_STATUS(_) => Outputs::none(),
            MavMessage::TIMESYNC(t) => {
                Outputs { mav: timesync::answer(from, t, now).into_iter().collect(), graph: Vec::new() }
            }
            MavMessage::COMMAND_ACK(_) => match self.accelcal.on_ack() {
                Some(request) => {
                    Outputs { mav: Vec::new(), graph: vec![ToGraph::Calibration { id: 0, request }] }
                }
                None => Outputs::none(),
            },
            MavMessage::COMMAND_LONG(c) => self.on_command(command_long(from, c), now),
            MavMessage::COMMAND_INT(c) => self.on_command(command_int(from, c), now),
            MavMessage::SET_MODE(m) => self.commands.set_mode(from, m.base_mode.bits(), m.custom_mode, now),
            MavMessage::REQUEST_DATA_STREAM(r) => {
                self.telemetry.request_data_stream(
                    r.req_stream_id,
                    r.req_message_rate,
                    r.start_stop != 0,
                    now,
                );
                Outputs::none()
            }
            MavMessage::MISSION_SET_CURRENT(m) => {
                let mut out = self.missions.set_current(m.seq);
                if let Some(index) = self.missions.commander_index(m.seq) {
                    out.mav.extend(self.telemetry.mission_current_if_shown(index));
                }
                out
            }
            MavMessage::FILE_TRANSFER_PROTOCOL(m) => {
                Outputs { mav: self.ftp.on_request(from, m, &self.params, now), graph: Vec::new() }
            }
            MavMessage::MANUAL_CONTROL(m) => Outputs {
                mav: Vec::new(),
                graph: manual_control(m, from.target_system(), now, &mut self.offboard_rejects)
                    .map(ToGraph::Manual)
                    .into_iter()
                    .collect(),
            },
            MavMessage::SET_POSITION_TARGET_LOCAL_NED(m) => {
                let nav = self.telemetry.snapshot.nav.as_ref();
                let c = local_target(m, nav, &mut self.offboard_rejects);
                Outputs { mav: Vec::new(), graph: vec![ToGraph::Command(c)] }
            }
            MavMessage::SET_POSITION_TARGET_GLOBAL_INT(m) => {
                let home = home(&self.telemetry.snapshot);
                let c = global_target(m, home, &mut self.offboard_rejects);
                Outputs { mav: Vec::new(), graph: vec![ToGraph::Command(c)] }
            }
            MavMessage::FOLLOW_TARGET(_) | MavMessage::GLOBAL_POSITION_INT(_) => {
                match follow::report(from, msg) {
                    Some(Ok(command)) => Outputs { mav: Vec::new(), graph: vec![ToGraph::Command(command)] },
                    Some(Err(why)) => {
                        tracing::debug!(system_id = from.system_id, %why, "position report not passed on");
                        Outputs::none()
                    }
                    None => Outputs::none(),
                }
            }
            MavMessage::SET_ATTITUDE_TARGET(m) => Outputs {
                mav: Vec::new(),
                graph: vec![ToGraph::Command(attitude_target(m, &mut self.offboard_rejects))],
            },
            _ => {
                self.unhandled += 1;
                Outputs::none()
            }
        }
    }

    /// A COMMAND_ACK from a ground station (decoded or not: see [`calibration::AccelcalSnoop`]):
    /// the accelerometer calibration's position confirmed, when one is asked for; unanswered,
    /// as an acknowledgement is.
    pub fn on_gcs_ack(&mut self) -> Outputs {
        match self.accelcal.on_ack() {
            Some(request) => {
                Outputs { mav: Vec::new(), graph: vec![ToGraph::Calibration { id: 0, request }] }
            }
            None => Outputs::none(),
        }
    }

    fn on_command(&mut self, request: CommandRequest, now: Time) -> Outputs {
        self.accelcal.on_command(request.command);
        let ctx = command::Context {
            autopilot_version: self.autopilot_version(),
            heartbeat: self.heartbeat(),
            telemetry: &mut self.telemetry,
            missions: &self.missions,
            failure_injector: self.params.is_declared(FAILURE_INJECTION_ENABLE),
        };
        self.commands.on_command(request, ctx, now)
    }

    /// The commander's new status: STATUSTEXTs and ACKs for what changed, MISSION_ITEM_REACHED
    /// for every item reached, and HOME_POSITION / MISSION_CURRENT at once when home or the
    /// current item moved (a ground station should not wait for the stream). The armed state
    /// goes to the parameter table, which refuses disarmed-only parameters while armed.
    pub fn on_status(&mut self, status: VehicleStatus) -> Outputs {
        self.params.set_armed(status.armed);
        self.health.set_armed(status.armed);
        self.logs.set_armed(status.armed);
        let old = self.telemetry.snapshot.status.take();
        self.missions.set_flying(status.armed && status.mode == FlightMode::Auto);
        let mut mav = status_changes(old.as_ref(), &status);
        let reached_before = old.as_ref().map_or(0, |o| o.mission.reached);
        let newly = status.mission.reached.saturating_sub(reached_before);
        if let Some(last) = status.mission.last_reached.filter(|_| newly > 0) {
            // Items reached since the last status run up to `last_reached`; the commander's item
            // i is our item i + 1 (item 0 is home).
            for index in (last + 1).saturating_sub(newly)..=last {
                mav.push(MavMessage::MISSION_ITEM_REACHED(MISSION_ITEM_REACHED_DATA {
                    seq: u16::try_from(index + 1).unwrap_or(u16::MAX),
                }));
            }
        }
        let home_moved = old.as_ref().is_some_and(|o| o.home != status.home);
        let item_moved = old.as_ref().is_some_and(|o| o.mission.current != status.mission.current);
        self.telemetry.snapshot.status = Some(status);
        // The stored mission's size as of now, not the last tick: a MISSION_CURRENT sent at once
        // for a mission just replaced carries the new total.
        self.telemetry.snapshot.mission_items =
            u16::try_from(self.missions.mission_len()).unwrap_or(u16::MAX);
        let now = self.telemetry.snapshot.status.as_ref().map_or(Time::ZERO, |s| s.time);
        for (moved, id) in [(home_moved, HOME_POSITION_DATA::ID), (item_moved, MISSION_CURRENT_DATA::ID)] {
            if moved {
                mav.extend(self.telemetry.build(id, now));
            }
        }
        Outputs { mav, graph: Vec::new() }
    }

    /// The commander's answer to a command: its COMMAND_ACK.
    pub fn on_command_result(&mut self, result: &CommandResult) -> Outputs {
        Outputs { mav: self.commands.on_result(result).into_iter().collect(), graph: Vec::new() }
    }

    /// The injector's answer to a failure injection: its COMMAND_ACK and a STATUSTEXT.
    pub fn on_injection_result(&mut self, result: &FailureInjectionResult) -> Outputs {
        Outputs { mav: self.commands.on_injection_result(result), graph: Vec::new() }
    }

    /// A calibration update: the answer becomes its command's COMMAND_ACK, results are set (and
    /// persisted) as a PARAM_SET would set them, the rest goes to the ground station.
    pub fn on_calibration(&mut self, event: &CalibrationEvent) -> Outputs {
        match &event.update {
            CalibrationUpdate::Answer { id, refusal } => Outputs {
                mav: self.commands.on_answer(*id, refusal.is_some()).into_iter().collect(),
                graph: Vec::new(),
            },
            CalibrationUpdate::Results { params } => {
                let mut out = Outputs::none();
                for (name, value) in params {
                    // Persisted once the owner declares the value back, as a PARAM_SET is.
                    out.extend(self.params.set(name, *value as f32, event.time));
                }
                out
            }
            update => {
                self.accelcal.on_update(update);
                Outputs { mav: calibration::messages(event, &mut self.text_id), graph: Vec::new() }
            }
        }
    }

    /// The estimator's latest state.
    pub fn on_nav(&mut self, nav: NavState) {
        self.telemetry.snapshot.nav = Some(nav);
    }

    /// The estimator's latest innovations and health (EKF_STATUS_REPORT), and a STATUSTEXT
    /// warning for each finding that began (`services::estimator_text`).
    pub fn on_estimator(&mut self, status: EstimatorStatus) -> Outputs {
        let old = self.telemetry.snapshot.estimator.as_ref().map(|s| s.health);
        let texts = estimator_text::estimator_changes(old.as_ref(), &status.health);
        self.telemetry.snapshot.estimator = Some(status);
        let mav = texts
            .iter()
            .flat_map(|t| calibration::chunked(MavSeverity::MAV_SEVERITY_WARNING, t, &mut self.text_id))
            .collect();
        Outputs { mav, graph: Vec::new() }
    }

    /// The latest GPS fix.
    pub fn on_gps(&mut self, gps: GpsFix) {
        self.telemetry.snapshot.gps = Some(gps);
    }

    /// The latest battery state.
    pub fn on_battery(&mut self, battery: BatteryStatus) {
        self.telemetry.snapshot.battery = Some(battery);
    }

    /// The latest depth grid (for OBSTACLE_DISTANCE).
    pub fn on_depth(&mut self, depth: DepthGrid) {
        self.telemetry.snapshot.depth = Some(depth);
    }

    /// A driver's or the recorder's health report: an error is a STATUSTEXT warning when
    /// [`HealthAnnouncer`] says it is due (at once when new, then as ArduCopter repeats a failing
    /// pre-arm check).
    pub fn on_sensor_health(&mut self, health: &SensorHealth) -> Outputs {
        let Some(text) = self.health.on_report(health) else { return Outputs::none() };
        Outputs {
            mav: calibration::chunked(MavSeverity::MAV_SEVERITY_WARNING, &text, &mut self.text_id),
            graph: Vec::new(),
        }
    }

    /// The simulator's latest ground truth (for SIMSTATE).
    pub fn on_truth(&mut self, truth: GroundTruth) {
        self.telemetry.snapshot.truth = Some(truth);
    }

    /// A rangefinder's newest sample (for DISTANCE_SENSOR); an unusable one is dropped.
    pub fn on_rangefinder(&mut self, sample: RangefinderSample) {
        self.telemetry.on_rangefinder(sample);
    }

    /// The avoider's latest correction (for DEBUG_VECT "AVOID").
    pub fn on_avoidance(&mut self, avoidance: AvoidanceCommand) {
        self.telemetry.snapshot.avoidance = Some(avoidance);
    }

    /// The IMU's newest sample (for RAW_IMU, SCALED_IMU, HIGHRES_IMU).
    pub fn on_imu(&mut self, imu: ImuSample) {
        self.telemetry.snapshot.imu = Some(imu);
    }

    /// The barometer's newest sample (for SCALED_PRESSURE).
    pub fn on_baro(&mut self, baro: BaroSample) {
        self.telemetry.snapshot.baro = Some(baro);
    }

    /// The mixer's newest motor outputs (for SERVO_OUTPUT_RAW).
    pub fn on_actuators(&mut self, actuators: ActuatorOutputs) {
        self.telemetry.snapshot.actuators = Some(actuators);
    }

    /// Pulses driven directly while disarmed (a motor test's), for SERVO_OUTPUT_RAW.
    pub fn on_esc_pulses(&mut self, pulses: EscPulses) {
        self.telemetry.snapshot.esc_pulses = Some(pulses);
    }

    /// The newest sticks on the graph (for RC_CHANNELS).
    pub fn on_sticks(&mut self, sticks: kestrel_proto::messages::ManualControl) {
        self.telemetry.snapshot.sticks = Some(sticks);
    }

    /// The commander's newest setpoint (for POSITION_TARGET_* and NAV_CONTROLLER_OUTPUT).
    pub fn on_setpoint(&mut self, setpoint: kestrel_proto::messages::Setpoint) {
        self.telemetry.snapshot.setpoint = Some(setpoint);
    }

    /// Periodic work: command and mission timeouts, GCS loss; returns replies and the telemetry
    /// due now (kept apart so radio links can thin telemetry only).
    pub fn on_tick(&mut self, now: Time) -> (Outputs, Vec<MavMessage>) {
        let mut out = Outputs { mav: self.commands.on_tick(now), graph: Vec::new() };
        out.extend(self.params.on_tick(now));
        out.extend(self.missions.on_tick(now));
        out.extend(self.logs.on_tick(now));
        if self.gcs.check(now) == Some(GcsEvent::Lost) {
            out.mav.push(statustext(MavSeverity::MAV_SEVERITY_CRITICAL, "GCS heartbeat lost"));
        }
        self.telemetry.snapshot.mission_items =
            u16::try_from(self.missions.mission_len()).unwrap_or(u16::MAX);
        (out, self.telemetry.due(now))
    }
}

fn command_long(from: Sender, c: &COMMAND_LONG_DATA) -> CommandRequest {
    CommandRequest {
        command: c.command,
        params: [c.param1, c.param2, c.param3, c.param4, c.param5, c.param6, c.param7].map(f64::from),
        frame: None,
        sender: from,
    }
}

fn command_int(from: Sender, c: &COMMAND_INT_DATA) -> CommandRequest {
    CommandRequest {
        command: c.command,
        params: [
            f64::from(c.param1),
            f64::from(c.param2),
            f64::from(c.param3),
            f64::from(c.param4),
            f64::from(c.x),
            f64::from(c.y),
            f64::from(c.z),
        ],
        frame: Some(c.frame),
        sender: from,
    }
}

impl Station for Vehicle {
    type Graph = ToGraph;

    fn identity(&self) -> Option<(u8, u8)> {
        Some((self.system_id, COMPONENT_ID))
    }

    /// Only this process speaks with our system id, whatever the component.
    fn claims_ours(&self, frame: &Frame) -> bool {
        frame.system_id == u32::from(self.system_id)
    }

    fn is_for_us(&self, msg: &MavMessage) -> bool {
        Vehicle::is_for_us(self, msg)
    }

    fn receive(
        &mut self,
        _endpoint: EndpointIndex,
        sender: Sender,
        frame: &Frame,
        msg: Option<&MavMessage>,
        now: Time,
    ) -> StationOut<ToGraph> {
        let out = match msg {
            // QGroundControl (command 0) and MAVProxy (1..6) confirm an accelerometer calibration
            // position with a COMMAND_ACK naming no MAV_CMD, which the dialect cannot decode; that
            // an acknowledgement came is all ArduPilot's snoop reads of it.
            None if frame.message_id == COMMAND_ACK_DATA::ID => self.on_gcs_ack(),
            Some(msg) if Vehicle::is_for_us(self, msg) => self.on_message(sender, msg, now),
            _ => Outputs::none(),
        };
        StationOut { mav: out.mav, telemetry: Vec::new(), graph: out.graph }
    }

    fn heartbeat(&self) -> Option<MavMessage> {
        Some(Vehicle::heartbeat(self))
    }

    fn on_tick(&mut self, now: Time) -> StationOut<ToGraph> {
        let (out, telemetry) = Vehicle::on_tick(self, now);
        StationOut { mav: out.mav, telemetry, graph: out.graph }
    }

    fn unhandled(&self) -> u64 {
        self.unhandled
    }

    fn take_param_write(&mut self) -> Option<ParamWrite> {
        Vehicle::take_param_write(self)
    }

    fn signing_store_id(&self) -> u8 {
        self.system_id
    }
}

#[cfg(test)]
mod tests;

/// Every command of the dialect, sent once with random parameters, gets exactly one
/// COMMAND_ACK, addressed to its sender; one that reaches the commander is answered by the
/// commander's result (accepted or refused) and never again, and an UNSUPPORTED one reaches
/// nothing in the graph, so the vehicle neither arms nor moves for it.
#[cfg(test)]
mod one_ack_per_command;
