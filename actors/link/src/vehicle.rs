//! The vehicle as a MAVLink component (sysid from config, compid 1): dispatches decoded messages
//! addressed to us to the microservices and gathers their answers. Synchronous and I/O-free.
#![allow(
    deprecated,
    reason = "legacy MAVLink (MISSION_ITEM, REQUEST_DATA_STREAM, SET_MODE, *_INT frames) is still spoken by ground stations and must be accepted"
)]

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::messages::{BatteryStatus, Command, DepthGrid, GpsFix, NavState, VehicleStatus};
use mavlink::Message;
use mavlink::dialects::ardupilotmega::{
    AUTOPILOT_VERSION_DATA, COMMAND_INT_DATA, COMMAND_LONG_DATA, MISSION_ITEM_REACHED_DATA, MavCmd,
    MavMessage, MavProtocolCapability, MavResult, MavSeverity, MavType,
};

use crate::services::command::{CommandRequest, CommandService, ack};
use crate::services::events::{status_changes, statustext};
use crate::services::heartbeat::{GcsEvent, GcsWatch, vehicle_heartbeat};
use crate::services::mission::MissionService;
use crate::services::offboard::{
    OffboardRejects, global_echo, global_target, local_echo, local_target, manual_control,
};
use crate::services::params::ParamTable;
use crate::services::telemetry::{Telemetry, home};
use crate::services::{Outputs, Sender, ToGraph};

/// Our component id (MAV_COMP_ID_AUTOPILOT1).
pub const COMPONENT_ID: u8 = 1;

/// PARAM_VALUEs sent per scheduler tick while a parameter list is streaming: a burst of hundreds
/// of datagrams overflows a ground station's socket buffer, 25 per 20 ms (1250/s) does not.
pub const PARAMS_PER_TICK: usize = 25;

/// What we claim in AUTOPILOT_VERSION: only what this crate implements.
pub fn capabilities() -> MavProtocolCapability {
    MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_INT
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_COMMAND_INT
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MAVLINK2
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
    /// Set when a parameter changed and should be persisted.
    params_changed: bool,
    /// Next index of a PARAM_REQUEST_LIST being streamed.
    param_cursor: Option<usize>,
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
            params_changed: false,
            param_cursor: None,
        }
    }

    /// Our system id.
    pub fn system_id(&self) -> u8 {
        self.system_id
    }

    /// The parameter table (for persisting).
    pub fn params(&self) -> &ParamTable {
        &self.params
    }

    /// True once after each accepted PARAM_SET.
    pub fn take_params_changed(&mut self) -> bool {
        std::mem::take(&mut self.params_changed)
    }

    /// Whether `msg` is for us: no target, broadcast, or our system (and component 0 or ours).
    pub fn is_for_us(&self, msg: &MavMessage) -> bool {
        let sys_ok = msg.target_system_id().is_none_or(|t| t == 0 || t == self.system_id);
        let comp_ok = msg.target_component_id().is_none_or(|c| c == 0 || c == COMPONENT_ID);
        sys_ok && comp_ok
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
        match msg {
            MavMessage::HEARTBEAT(hb) if hb.mavtype == MavType::MAV_TYPE_GCS => {
                let mut out = Outputs { mav: Vec::new(), graph: vec![ToGraph::Command(Command::Heartbeat)] };
                if self.gcs.heard(now) == Some(GcsEvent::Regained) {
                    out.mav.push(statustext(MavSeverity::MAV_SEVERITY_INFO, "GCS link regained"));
                }
                out
            }
            MavMessage::HEARTBEAT(_) | MavMessage::RADIO_STATUS(_) => Outputs::none(),
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
            MavMessage::PARAM_REQUEST_LIST(_) => {
                self.param_cursor = Some(0);
                self.next_params()
            }
            MavMessage::PARAM_REQUEST_READ(r) => {
                let name = r.param_id.to_str().unwrap_or_default().trim_end_matches('\0');
                Outputs {
                    mav: self.params.read(name, r.param_index).into_iter().collect(),
                    graph: Vec::new(),
                }
            }
            MavMessage::PARAM_SET(s) => {
                let name = s.param_id.to_str().unwrap_or_default().trim_end_matches('\0').to_owned();
                let out = self.params.set(&name, s.param_value, now);
                self.params_changed |= !out.graph.is_empty();
                out
            }
            MavMessage::MISSION_COUNT(m) => self.missions.on_count(from, m, now),
            MavMessage::MISSION_ITEM_INT(m) => self.missions.on_item(from, m, now),
            MavMessage::MISSION_ITEM(m) => self.missions.on_item_float(from, m, now),
            MavMessage::MISSION_REQUEST_LIST(m) => self.missions.on_request_list(from, m.mission_type),
            MavMessage::MISSION_REQUEST_INT(m) => {
                self.missions.on_request(from, m.seq, m.mission_type, false)
            }
            MavMessage::MISSION_REQUEST(m) => self.missions.on_request(from, m.seq, m.mission_type, true),
            MavMessage::MISSION_CLEAR_ALL(m) => self.missions.clear(from, m.mission_type, now),
            MavMessage::MISSION_ACK(_) => {
                self.missions.on_ack(from);
                Outputs::none()
            }
            MavMessage::MANUAL_CONTROL(m) => Outputs {
                mav: Vec::new(),
                graph: manual_control(m, now, &mut self.offboard_rejects)
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

    fn on_command(&mut self, request: CommandRequest, now: Time) -> Outputs {
        let p = request.params;
        match request.command {
            MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL => {
                Outputs::send(ack(&request, self.telemetry.set_interval(p[0], p[1], now)))
            }
            MavCmd::MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES => Outputs {
                mav: vec![ack(&request, MavResult::MAV_RESULT_ACCEPTED), self.autopilot_version()],
                graph: Vec::new(),
            },
            MavCmd::MAV_CMD_REQUEST_MESSAGE => {
                let id = p[0];
                let msg = if id == f64::from(<AUTOPILOT_VERSION_DATA as mavlink::MessageData>::ID) {
                    Some(self.autopilot_version())
                } else if id == 0.0 {
                    Some(self.heartbeat())
                } else if (0.0..=f64::from(u32::MAX)).contains(&id) {
                    self.telemetry.build(id as u32, now)
                } else {
                    None
                };
                match msg {
                    Some(m) => Outputs {
                        mav: vec![ack(&request, MavResult::MAV_RESULT_ACCEPTED), m],
                        graph: Vec::new(),
                    },
                    None => Outputs::send(ack(&request, MavResult::MAV_RESULT_DENIED)),
                }
            }
            _ => match self.commands.handle(request, now) {
                Some(out) => out,
                None => Outputs::send(ack(&request, MavResult::MAV_RESULT_UNSUPPORTED)),
            },
        }
    }

    fn next_params(&mut self) -> Outputs {
        let Some(start) = self.param_cursor else { return Outputs::none() };
        let end = (start + PARAMS_PER_TICK).min(self.params.len());
        let mav = (start..end).filter_map(|i| self.params.read("", i16::try_from(i).ok()?)).collect();
        self.param_cursor = (end < self.params.len()).then_some(end);
        Outputs { mav, graph: Vec::new() }
    }

    /// The commander's new status.
    pub fn on_status(&mut self, status: VehicleStatus) -> Outputs {
        let old = self.telemetry.snapshot.status.take();
        let mut mav = status_changes(old.as_ref(), &status);
        mav.extend(self.commands.on_status(&status));
        let reached_before = old.map_or(0, |o| o.mission.reached);
        for reached in reached_before + 1..=status.mission.reached {
            // The commander's item `reached - 1` is our item `reached` (item 0 is home).
            mav.push(MavMessage::MISSION_ITEM_REACHED(MISSION_ITEM_REACHED_DATA {
                seq: u16::try_from(reached).unwrap_or(u16::MAX),
            }));
        }
        self.telemetry.snapshot.status = Some(status);
        Outputs { mav, graph: Vec::new() }
    }

    /// The estimator's latest state.
    pub fn on_nav(&mut self, nav: NavState) {
        self.telemetry.snapshot.nav = Some(nav);
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

    /// Periodic work: command and mission timeouts, GCS loss; returns replies and the telemetry
    /// due now (kept apart so radio links can thin telemetry only).
    pub fn on_tick(&mut self, now: Time) -> (Outputs, Vec<MavMessage>) {
        let mut out = Outputs { mav: self.commands.on_tick(now), graph: Vec::new() };
        out.extend(self.missions.on_tick(now));
        out.extend(self.next_params());
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
        sender: from,
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::messages::{FlightMode, LandedState, MissionProgress};
    use mavlink::dialects::ardupilotmega::{HEARTBEAT_DATA, PARAM_REQUEST_LIST_DATA};

    use super::*;
    use crate::config::{ParamKind, ParamSpec};

    const GCS: Sender = Sender { system_id: 255, component_id: 190 };

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

    fn status(reached: u32) -> VehicleStatus {
        VehicleStatus {
            time: Time::ZERO,
            armed: true,
            mode: FlightMode::Auto,
            landed: LandedState::InAir,
            failsafe: None,
            mission: MissionProgress { current: reached, reached, total: 5, completed: false },
            last_refusal: None,
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
        assert_eq!(v.on_message(GCS, &gcs, Time::ZERO).graph, vec![ToGraph::Command(Command::Heartbeat)]);
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

    #[test]
    fn a_parameter_list_streams_over_ticks() {
        let mut v = vehicle(60);
        let list =
            MavMessage::PARAM_REQUEST_LIST(PARAM_REQUEST_LIST_DATA { target_system: 7, target_component: 1 });
        let mut n = v.on_message(GCS, &list, Time::ZERO).mav.len();
        assert_eq!(n, PARAMS_PER_TICK);
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
