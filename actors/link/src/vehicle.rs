//! The vehicle as a MAVLink component (sysid from config, compid 1): dispatches decoded messages
//! addressed to us to the microservices and gathers their answers. Synchronous and I/O-free.
#![allow(
    deprecated,
    reason = "legacy MAVLink (MISSION_ITEM, REQUEST_DATA_STREAM, SET_MODE, *_INT frames) is still spoken by ground stations and must be accepted"
)]

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::messages::{
    AvoidanceCommand, BatteryStatus, CalibrationEvent, CalibrationUpdate, Command, CommandResult, DepthGrid,
    EstimatorStatus, FAILURE_INJECTION_ENABLE, FailureInjectionResult, FlightMode, GpsFix, GroundTruth,
    NavState, ParamDecl, RangefinderSample, SensorHealth, VehicleStatus,
};
use mavlink::dialects::ardupilotmega::{
    AUTOPILOT_VERSION_DATA, COMMAND_INT_DATA, COMMAND_LONG_DATA, HOME_POSITION_DATA, MISSION_CURRENT_DATA,
    MISSION_ITEM_REACHED_DATA, MavMessage, MavProtocolCapability, MavSeverity, MavType,
};
use mavlink::{Message, MessageData};

use crate::services::command::{self, CommandRequest, CommandService};
use crate::services::events::{status_changes, statustext};
use crate::services::ftp::FtpServer;
use crate::services::heartbeat::{GcsEvent, GcsWatch, vehicle_heartbeat};
use crate::services::log_download::{LogDirectory, LogDownload};
use crate::services::mission::MissionService;
use crate::services::offboard::{
    OffboardRejects, global_echo, global_target, local_echo, local_target, manual_control,
};
use crate::services::params::ParamTable;
use crate::services::telemetry::{Telemetry, home};
use crate::services::{Outputs, Sender, Service, ToGraph};
use crate::services::{calibration, estimator_text};

/// Our component id (MAV_COMP_ID_AUTOPILOT1).
pub const COMPONENT_ID: u8 = 1;

/// The parameter naming the ground station in control (ArduPilot 4.7's name for SYSID_MYGCS),
/// declared by the commander, and its default there and in ArduPilot.
const GCS_SYSID_PARAM: &str = "MAV_GCS_SYSID";
const DEFAULT_GCS_SYSID: u8 = 255;

/// What we claim in AUTOPILOT_VERSION: only what this crate implements (FTP is read-only: the
/// logs and `@PARAM/param.pck`, see `services::ftp`).
pub fn capabilities() -> MavProtocolCapability {
    MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_INT
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_COMMAND_INT
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MAVLINK2
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_FTP
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

    /// True once after each change the parameter file must follow.
    pub fn take_params_changed(&mut self) -> bool {
        self.params.take_changed()
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
            MavMessage::SET_POSITION_TARGET_LOCAL_NED(m) => match local_target(m, &mut self.offboard_rejects)
            {
                Some(c) => Outputs { mav: vec![local_echo(m, now)], graph: vec![ToGraph::Command(c)] },
                None => Outputs::none(),
            },
            MavMessage::SET_POSITION_TARGET_GLOBAL_INT(m) => {
                let home = home(&self.telemetry.snapshot);
                match global_target(m, home, &mut self.offboard_rejects) {
                    Some(c) => Outputs { mav: vec![global_echo(m, now)], graph: vec![ToGraph::Command(c)] },
                    None => Outputs::none(),
                }
            }
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

    /// A driver's health report: errors in its window are a STATUSTEXT warning (one per report,
    /// so at most one a second per driver), as ArduPilot reports a failing sensor.
    pub fn on_sensor_health(&mut self, health: &SensorHealth) -> Outputs {
        if health.errors == 0 {
            return Outputs::none();
        }
        let text =
            format!("{}: {} errors in the last second ({})", health.sensor, health.errors, health.device);
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

#[cfg(test)]
mod tests {
    use kestrel_proto::messages::{LandedState, MissionProgress};
    use mavlink::dialects::ardupilotmega::{HEARTBEAT_DATA, MavCmd, MavResult, PARAM_REQUEST_LIST_DATA};

    use super::*;
    use crate::config::{ParamKind, ParamSpec};

    const GCS: Sender = Sender { system_id: 255, component_id: 190 };

    /// A NavState at rest on the origin of Moratuwa's frame (what DO_REPOSITION and
    /// GET_HOME_POSITION need).
    pub(super) fn at_origin() -> kestrel_proto::messages::NavState {
        use kestrel_proto::geo::Geodetic;
        use kestrel_proto::messages::{NavState, NavValidity};
        NavState {
            time: Time::ZERO,
            attitude: [1.0, 0.0, 0.0, 0.0],
            angular_velocity_rad_s: [0.0; 3],
            velocity_ned_m_s: [0.0; 3],
            position_ned_m: [0.0; 3],
            gyro_bias_rad_s: [0.0; 3],
            accel_bias_m_s2: [0.0; 3],
            covariance_diagonal: [0.0; 16],
            origin: Some(Geodetic { lat_deg: 6.79710, lon_deg: 79.90170, alt_m: 20.0 }),
            valid: NavValidity::default(),
        }
    }

    fn vehicle(params: usize) -> Vehicle {
        let specs = (0..params)
            .map(|i| ParamSpec {
                name: format!("P{i}"),
                value: 0.0,
                min: 0.0,
                max: 1.0,
                kind: ParamKind::Real32,
                unit: String::new(),
            })
            .collect();
        Vehicle::new(7, ParamTable::new(specs).expect("valid"), Duration::from_secs(5))
    }

    #[test]
    fn driver_errors_become_one_warning_per_report() {
        let mut v = vehicle(0);
        let health = |errors| SensorHealth {
            time: Time::ZERO,
            sensor: "motors".into(),
            device: "/sys/class/pwm/pwmchip0".into(),
            rate_hz: 1600.0,
            errors,
            errors_total: errors,
            clipped: 0,
        };
        assert!(v.on_sensor_health(&health(0)).mav.is_empty(), "a healthy driver is quiet");
        let out = v.on_sensor_health(&health(20));
        let mut text = String::new();
        for m in &out.mav {
            let MavMessage::STATUSTEXT(t) = m else { panic!("{m:?}") };
            assert_eq!(t.severity, MavSeverity::MAV_SEVERITY_WARNING);
            text.push_str(String::from_utf8_lossy(&t.text.to_vec()).trim_end_matches('\0'));
        }
        assert_eq!(text, "motors: 20 errors in the last second (/sys/class/pwm/pwmchip0)");
    }

    fn status(reached: u32) -> VehicleStatus {
        VehicleStatus {
            mission: MissionProgress {
                current: reached,
                reached,
                last_reached: reached.checked_sub(1),
                total: 5,
                completed: false,
            },
            ..kestrel_proto::testing::vehicle_status(Time::ZERO, true, FlightMode::Auto, LandedState::InAir)
        }
    }

    fn long(command: MavCmd, param1: f32, target_system: u8) -> MavMessage {
        MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            command,
            param1,
            target_system,
            target_component: 1,
            ..Default::default()
        })
    }

    fn ack_result(out: &Outputs) -> Option<MavResult> {
        out.mav.iter().find_map(|m| match m {
            MavMessage::COMMAND_ACK(a) => Some(a.result),
            _ => None,
        })
    }

    #[test]
    fn only_messages_for_our_system_and_component_are_ours() {
        let v = vehicle(0);
        assert!(v.is_for_us(&long(MavCmd::MAV_CMD_NAV_LAND, 0.0, 7)));
        assert!(v.is_for_us(&long(MavCmd::MAV_CMD_NAV_LAND, 0.0, 0)));
        assert!(!v.is_for_us(&long(MavCmd::MAV_CMD_NAV_LAND, 0.0, 8)));
        assert!(v.is_for_us(&MavMessage::HEARTBEAT(HEARTBEAT_DATA::default())));
    }

    #[test]
    fn gcs_heartbeats_feed_the_data_link_timer_and_others_do_not() {
        let mut v = vehicle(0);
        let gcs =
            MavMessage::HEARTBEAT(HEARTBEAT_DATA { mavtype: MavType::MAV_TYPE_GCS, ..Default::default() });
        assert_eq!(
            v.on_message(GCS, &gcs, Time::ZERO).graph,
            vec![ToGraph::Command(Command::Heartbeat { system_id: 255 })]
        );
        // Another ground station's is passed on with its id: the commander decides.
        let other_gcs = Sender { system_id: 254, component_id: 190 };
        assert_eq!(
            v.on_message(other_gcs, &gcs, Time::ZERO).graph,
            vec![ToGraph::Command(Command::Heartbeat { system_id: 254 })]
        );
        let other = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            mavtype: MavType::MAV_TYPE_QUADROTOR,
            ..Default::default()
        });
        assert!(v.on_message(GCS, &other, Time::ZERO).graph.is_empty());
    }

    #[test]
    fn request_message_and_intervals_are_answered() {
        let mut v = vehicle(0);
        let out = v.on_message(GCS, &long(MavCmd::MAV_CMD_REQUEST_MESSAGE, 148.0, 7), Time::ZERO);
        assert_eq!(ack_result(&out), Some(MavResult::MAV_RESULT_ACCEPTED));
        assert!(matches!(out.mav[1], MavMessage::AUTOPILOT_VERSION(_)));
        let out = v.on_message(GCS, &long(MavCmd::MAV_CMD_REQUEST_MESSAGE, 33.0, 7), Time::ZERO);
        assert_eq!(ack_result(&out), Some(MavResult::MAV_RESULT_DENIED), "no position known yet");
        let out = v.on_message(GCS, &long(MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL, 30.0, 7), Time::ZERO);
        assert_eq!(ack_result(&out), Some(MavResult::MAV_RESULT_ACCEPTED), "interval 0 restores the default");
    }

    #[test]
    fn reached_items_are_reported_once_each_with_the_home_offset() {
        let mut v = vehicle(0);
        v.on_status(status(0));
        let out = v.on_status(status(2));
        let seqs: Vec<u16> = out
            .mav
            .iter()
            .filter_map(|m| match m {
                MavMessage::MISSION_ITEM_REACHED(r) => Some(r.seq),
                _ => None,
            })
            .collect();
        assert_eq!(seqs, [1, 2]);
        assert!(v.on_status(status(2)).mav.is_empty());
    }

    /// Uploads home plus `n` waypoints through the mission protocol.
    fn with_mission(v: &mut Vehicle, n: u16) {
        use mavlink::dialects::ardupilotmega::{
            MISSION_COUNT_DATA, MISSION_ITEM_INT_DATA, MavFrame, MavMissionResult, MavMissionType,
        };
        let count =
            MISSION_COUNT_DATA { count: n + 1, target_system: 7, target_component: 1, ..Default::default() };
        v.on_message(GCS, &MavMessage::MISSION_COUNT(count), Time::ZERO);
        let mut last = Outputs::none();
        for seq in 0..=n {
            let item = MISSION_ITEM_INT_DATA {
                seq,
                command: MavCmd::MAV_CMD_NAV_WAYPOINT,
                frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                x: 67_971_000 + i32::from(seq) * 100,
                y: 799_017_000,
                z: 10.0,
                target_system: 7,
                target_component: 1,
                mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
                ..Default::default()
            };
            last = v.on_message(GCS, &MavMessage::MISSION_ITEM_INT(item), Time::ZERO);
        }
        assert!(last.mav.iter().any(
            |m| matches!(m, MavMessage::MISSION_ACK(a) if a.mavtype == MavMissionResult::MAV_MISSION_ACCEPTED)
        ));
    }

    fn set_current_command(seq: f32) -> MavMessage {
        long(MavCmd::MAV_CMD_DO_SET_MISSION_CURRENT, seq, 7)
    }

    #[test]
    fn set_mission_current_by_command_and_message_reaches_the_commander_or_is_refused() {
        use mavlink::dialects::ardupilotmega::MISSION_SET_CURRENT_DATA;
        let mut v = vehicle(0);
        let out = v.on_message(GCS, &set_current_command(1.0), Time::ZERO);
        assert_eq!(ack_result(&out), Some(MavResult::MAV_RESULT_FAILED), "no mission");
        with_mission(&mut v, 3);
        v.on_tick(Time::ZERO);
        v.on_status(status(0));
        let out = v.on_message(GCS, &set_current_command(3.0), Time::ZERO);
        let command = Command::SetMissionCurrent { index: 2 };
        assert_eq!(out.graph, vec![ToGraph::Request { id: 1, command }]);
        assert_eq!(ack_result(&out), None, "acknowledged once the commander answers");
        for bad in [4.0, 1.5, -3.0, f32::NAN] {
            let out = v.on_message(GCS, &set_current_command(bad), Time::ZERO);
            assert_eq!(ack_result(&out), Some(MavResult::MAV_RESULT_FAILED), "{bad}");
            assert!(out.graph.is_empty());
        }
        // The commander moves to item 2: ACCEPTED, and MISSION_CURRENT at once with our seq 3.
        let answer = CommandResult { time: Time::ZERO, id: 1, command, refusal: None };
        assert_eq!(ack_result(&v.on_command_result(&answer)), Some(MavResult::MAV_RESULT_ACCEPTED));
        let mut moved = status(0);
        moved.mission.current = 2;
        let out = v.on_status(moved);
        assert!(out.mav.iter().any(|m| matches!(m, MavMessage::MISSION_CURRENT(c) if c.seq == 3)));
        // The message: the same item again is answered with MISSION_CURRENT though nothing
        // changes; an item we do not have gets a STATUSTEXT.
        let set = |seq| {
            MavMessage::MISSION_SET_CURRENT(MISSION_SET_CURRENT_DATA {
                seq,
                target_system: 7,
                target_component: 1,
            })
        };
        let out = v.on_message(GCS, &set(3), Time::ZERO);
        assert_eq!(out.graph, vec![ToGraph::Command(Command::SetMissionCurrent { index: 2 })]);
        assert!(matches!(out.mav[..], [MavMessage::MISSION_CURRENT(_)]));
        let out = v.on_message(GCS, &set(9), Time::ZERO);
        assert!(out.graph.is_empty());
        assert!(matches!(out.mav[..], [MavMessage::STATUSTEXT(_)]));
    }

    #[test]
    fn a_mission_uploaded_while_flying_is_accepted_and_mission_current_describes_it() {
        use mavlink::dialects::ardupilotmega::{MISSION_CLEAR_ALL_DATA, MavMissionResult, MavMissionType};
        let mut v = vehicle(0);
        with_mission(&mut v, 3);
        v.on_tick(Time::ZERO);
        // Flying the commander's item 2 (our 3) in AUTO, a mission of 5 waypoints arrives.
        let mut flying = status(2);
        flying.mission.total = 3;
        v.on_status(flying.clone());
        with_mission(&mut v, 5);
        // The commander replaces it at the same index: MISSION_CURRENT carries our seq 3 of 5,
        // sent at once when the item moves, before any tick.
        flying.mission.total = 5;
        flying.mission.current = 1;
        v.on_status(flying.clone());
        flying.mission.current = 2;
        let out = v.on_status(flying);
        assert!(
            out.mav.iter().any(|m| matches!(m, MavMessage::MISSION_CURRENT(c) if (c.seq, c.total) == (3, 5))),
            "{out:?}"
        );
        let current = |v: &Vehicle| {
            v.telemetry.build(MISSION_CURRENT_DATA::ID, Time::ZERO).map(|m| match m {
                MavMessage::MISSION_CURRENT(c) => (c.seq, c.total),
                other => panic!("{other:?}"),
            })
        };
        assert_eq!(current(&v), Some((3, 5)));
        // Clearing it while it is flown is an error, and changes nothing.
        let clear = MISSION_CLEAR_ALL_DATA {
            target_system: 7,
            target_component: 1,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
        };
        let out = v.on_message(GCS, &MavMessage::MISSION_CLEAR_ALL(clear), Time::ZERO);
        assert!(out.mav.iter().any(
            |m| matches!(m, MavMessage::MISSION_ACK(a) if a.mavtype == MavMissionResult::MAV_MISSION_ERROR)
        ));
        assert!(out.graph.is_empty());
        v.on_tick(Time::ZERO);
        assert_eq!(current(&v), Some((3, 5)));
    }

    #[test]
    fn after_a_jump_reached_items_carry_their_own_numbers_and_home_moves_are_sent_at_once() {
        use kestrel_proto::messages::Home;
        let mut v = vehicle(0);
        v.on_status(status(0));
        let mut jumped = status(0);
        jumped.mission =
            MissionProgress { current: 3, reached: 1, last_reached: Some(2), total: 5, completed: false };
        let seqs: Vec<u16> = v
            .on_status(jumped.clone())
            .mav
            .iter()
            .filter_map(|m| match m {
                MavMessage::MISSION_ITEM_REACHED(r) => Some(r.seq),
                _ => None,
            })
            .collect();
        assert_eq!(seqs, [3], "the commander's item 2 is our item 3");
        v.on_nav(at_origin());
        let homed =
            VehicleStatus { home: Some(Home { position_ned_m: [5.0, 0.0, 0.0], revision: 3 }), ..jumped };
        let out = v.on_status(homed.clone());
        assert!(out.mav.iter().any(|m| matches!(m, MavMessage::HOME_POSITION(h) if h.x == 5.0)));
        assert!(!v.on_status(homed).mav.iter().any(|m| matches!(m, MavMessage::HOME_POSITION(_))));
    }

    #[test]
    fn ftp_opens_the_parameter_file_for_its_sender_and_is_claimed() {
        use mavlink::dialects::ardupilotmega::FILE_TRANSFER_PROTOCOL_DATA;
        let mut v = vehicle(0);
        let mut payload = [0u8; 251];
        payload[0] = 5; // sequence number 5
        payload[2] = 9; // session 9
        payload[3] = 4; // OpenFileRO
        let path = b"@PARAM/param.pck";
        payload[4] = path.len() as u8;
        payload[12..12 + path.len()].copy_from_slice(path);
        let request =
            FILE_TRANSFER_PROTOCOL_DATA { target_network: 0, target_system: 7, target_component: 1, payload };
        let out = v.on_message(GCS, &MavMessage::FILE_TRANSFER_PROTOCOL(request), Time::ZERO);
        let [MavMessage::FILE_TRANSFER_PROTOCOL(ack)] = &out.mav[..] else {
            panic!("no FTP answer: {out:?}")
        };
        // ACK (128) to OpenFileRO (4) with the file's size (4 bytes), sequence 6, session 9, to
        // the sender.
        let size = u32::from_le_bytes([ack.payload[12], ack.payload[13], ack.payload[14], ack.payload[15]]);
        let want = crate::services::param_pack::encode(&v.params().list()).len();
        assert_eq!((ack.payload[3], ack.payload[5], ack.payload[4], size as usize), (128, 4, 4, want));
        assert_eq!(
            (ack.payload[0], ack.payload[2], ack.target_system, ack.target_component),
            (6, 9, 255, 190)
        );
        assert_eq!(v.unhandled, 0);
        assert!(capabilities().contains(MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_FTP));
    }

    #[test]
    fn mission_start_from_a_first_item_makes_it_current_then_starts() {
        let mut v = vehicle(0);
        with_mission(&mut v, 3);
        let start = |v: &mut Vehicle, first: f32, last: f32| {
            let msg = MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
                command: MavCmd::MAV_CMD_MISSION_START,
                param1: first,
                param2: last,
                target_system: 7,
                target_component: 1,
                ..Default::default()
            });
            v.on_message(GCS, &msg, Time::ZERO)
        };
        let out = start(&mut v, 2.0, 0.0);
        assert_eq!(
            out.graph,
            vec![
                ToGraph::Command(Command::SetMissionCurrent { index: 1 }),
                ToGraph::Request { id: 1, command: Command::MissionStart }
            ]
        );
        assert_eq!(start(&mut v, 1.0, 3.0).graph.len(), 2, "to the last item is to the end");
        for (first, last) in [(2.0, 1.0), (9.0, 0.0), (1.5, 0.0), (f32::NAN, 0.0)] {
            let out = start(&mut v, first, last);
            assert!(out.graph.is_empty(), "{first} {last}");
            assert_eq!(ack_result(&out), Some(MavResult::MAV_RESULT_DENIED), "{first} {last}");
        }
    }

    #[test]
    fn a_parameter_list_streams_over_ticks() {
        let mut v = vehicle(60);
        let list =
            MavMessage::PARAM_REQUEST_LIST(PARAM_REQUEST_LIST_DATA { target_system: 7, target_component: 1 });
        let mut n = v.on_message(GCS, &list, Time::ZERO).mav.len();
        assert_eq!(n, crate::services::params::PARAMS_PER_TICK);
        for _ in 0..5 {
            n += v
                .on_tick(Time::ZERO)
                .0
                .mav
                .iter()
                .filter(|m| matches!(m, MavMessage::PARAM_VALUE(_)))
                .count();
        }
        assert_eq!(n, 60);
    }
}

/// Every command of the dialect, sent once with random parameters, gets exactly one
/// COMMAND_ACK, addressed to its sender; one that reaches the commander is answered by the
/// commander's result (accepted or refused) and never again, and an UNSUPPORTED one reaches
/// nothing in the graph, so the vehicle neither arms nor moves for it.
#[cfg(test)]
mod one_ack_per_command {
    use kestrel_proto::messages::CommandResult;
    use mavlink::dialects::ardupilotmega::{COMMAND_LONG_DATA, MavCmd, MavMessage, MavResult};
    use num_traits::FromPrimitive;
    use proptest::prelude::*;

    use super::{COMPONENT_ID, Vehicle};
    use crate::services::command::ACK_TIMEOUT;
    use crate::services::params::ParamTable;
    use crate::services::{Sender, ToGraph};
    use kestrel_proto::Time;

    const GCS: Sender = Sender { system_id: 245, component_id: 190 };

    /// Every MAV_CMD id the dialect knows (common and ArduPilot's).
    fn every_command() -> Vec<MavCmd> {
        (0..=u16::MAX.into()).filter_map(MavCmd::from_u32).collect()
    }

    fn param() -> impl Strategy<Value = f32> {
        prop_oneof![
            Just(0.0),
            Just(1.0),
            Just(-1.0),
            Just(f32::NAN),
            Just(f32::INFINITY),
            Just(f32::NEG_INFINITY),
            (0u32..100).prop_map(|n| n as f32),
            any::<f32>(),
            -1e3f32..1e3,
        ]
    }

    fn acks(mav: &[MavMessage], command: MavCmd) -> Vec<(MavResult, u8, u8)> {
        mav.iter()
            .filter_map(|m| match m {
                MavMessage::COMMAND_ACK(a) if a.command == command => {
                    Some((a.result, a.target_system, a.target_component))
                }
                _ => None,
            })
            .collect()
    }

    /// A vehicle that knows where it is (DO_REPOSITION, GET_HOME_POSITION need an origin).
    fn vehicle() -> Vehicle {
        let mut v =
            Vehicle::new(1, ParamTable::new(Vec::new()).expect("valid"), std::time::Duration::from_secs(5));
        v.on_nav(super::tests::at_origin());
        v
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 3000, ..ProptestConfig::default() })]
        #[test]
        fn every_command_gets_exactly_one_ack(
            index in any::<prop::sample::Index>(),
            p in prop::array::uniform7(param()),
            refused in any::<bool>(),
        ) {
            let commands = every_command();
            let command = commands[index.index(commands.len())];
            let mut v = vehicle();
            let msg = MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
                command,
                param1: p[0], param2: p[1], param3: p[2], param4: p[3], param5: p[4], param6: p[5], param7: p[6],
                target_system: 1,
                target_component: COMPONENT_ID,
                confirmation: 0,
            });
            let now = Time::from_secs_f64(1.0);
            let out = v.on_message(GCS, &msg, now);
            let mut answers = acks(&out.mav, command);
            let asked: Vec<u32> = out.graph.iter().filter_map(|g| match g {
                ToGraph::Request { id, .. } => Some(*id),
                _ => None,
            }).collect();
            prop_assert!(asked.len() <= 1, "{command:?}: {} requests", asked.len());
            for id in &asked {
                let refusal = refused.then(|| "refused".to_owned());
                let got = v.on_command_result(&CommandResult { time: now, id: *id, command: kestrel_proto::messages::Command::Heartbeat { system_id: 255 }, refusal });
                answers.extend(acks(&got.mav, command));
                // The same answer again (a duplicate on the graph) is not acknowledged twice.
                let again = v.on_command_result(&CommandResult { time: now, id: *id, command: kestrel_proto::messages::Command::Heartbeat { system_id: 255 }, refusal: None });
                answers.extend(acks(&again.mav, command));
            }
            let (late, _) = v.on_tick(now + ACK_TIMEOUT + ACK_TIMEOUT);
            answers.extend(acks(&late.mav, command));
            prop_assert_eq!(answers.len(), 1, "{:?} {:?}: {:?}", command, p, answers);
            let (result, system, component) = answers[0];
            prop_assert_eq!((system, component), (245, 190), "addressed to its sender");
            if result == MavResult::MAV_RESULT_UNSUPPORTED {
                prop_assert!(out.graph.is_empty(), "{command:?} is unsupported yet reached the graph: {:?}", out.graph);
            }
            if !asked.is_empty() {
                let want = if refused { MavResult::MAV_RESULT_DENIED } else { MavResult::MAV_RESULT_ACCEPTED };
                prop_assert_eq!(result, want, "{:?}: the commander's answer", command);
            }
        }
    }

    #[test]
    fn the_dialect_has_the_commands_ground_stations_send() {
        let all = every_command();
        assert!(all.len() > 150, "{} commands", all.len());
        for c in [
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            MavCmd::MAV_CMD_DO_REPOSITION,
            MavCmd::MAV_CMD_MISSION_START,
        ] {
            assert!(all.contains(&c));
        }
    }
}
