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
fn a_driver_error_is_a_warning_at_once_and_not_again_the_next_second() {
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
    assert!(v.on_sensor_health(&health(20)).mav.is_empty(), "repeated every 30 s, not every report");
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
    let gcs = MavMessage::HEARTBEAT(HEARTBEAT_DATA { mavtype: MavType::MAV_TYPE_GCS, ..Default::default() });
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
    let other =
        MavMessage::HEARTBEAT(HEARTBEAT_DATA { mavtype: MavType::MAV_TYPE_QUADROTOR, ..Default::default() });
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
    let homed = VehicleStatus { home: Some(Home { position_ned_m: [5.0, 0.0, 0.0], revision: 3 }), ..jumped };
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
    let [MavMessage::FILE_TRANSFER_PROTOCOL(ack)] = &out.mav[..] else { panic!("no FTP answer: {out:?}") };
    // ACK (128) to OpenFileRO (4) with the file's size (4 bytes), sequence 6, session 9, to
    // the sender.
    let size = u32::from_le_bytes([ack.payload[12], ack.payload[13], ack.payload[14], ack.payload[15]]);
    let want = crate::services::param_pack::encode(&v.params().list()).len();
    assert_eq!((ack.payload[3], ack.payload[5], ack.payload[4], size as usize), (128, 4, 4, want));
    assert_eq!((ack.payload[0], ack.payload[2], ack.target_system, ack.target_component), (6, 9, 255, 190));
    assert_eq!(v.unhandled, 0);
    assert!(capabilities().contains(MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_FTP));
    assert!(capabilities().contains(MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_RALLY));
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
        n += v.on_tick(Time::ZERO).0.mav.iter().filter(|m| matches!(m, MavMessage::PARAM_VALUE(_))).count();
    }
    assert_eq!(n, 60);
}
