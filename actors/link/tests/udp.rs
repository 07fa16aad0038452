//! The link over real loopback UDP sockets against a peer built on the `mavlink` crate:
//! heartbeat to the ground-station address, MAVLink 1 and 2 inbound, parameters, commands,
//! mission upload/download, routing between peers, malformed input and signing.

mod common;
#[path = "common/peer.rs"]
mod peer;

use std::net::{Ipv4Addr, SocketAddr};
use std::time::{Duration, Instant};

use common::Harness;
use kestrel_link::config::{EndpointConfig, EndpointKind};
use kestrel_link::services::ToGraph;
use kestrel_proto::messages::Command;
use mavlink::dialects::ardupilotmega::*;
use mavlink::{MavlinkVersion, SigningConfig, SigningData};
use peer::Peer;

const WAIT: Duration = Duration::from_secs(3);

fn loopback0() -> SocketAddr {
    (Ipv4Addr::LOCALHOST, 0).into()
}

fn udp_out(to: SocketAddr) -> EndpointConfig {
    EndpointConfig {
        kind: EndpointKind::UdpOut { address: to, bind: None, per_instance: false },
        signing_key_file: None,
    }
}

fn udp_in() -> EndpointConfig {
    EndpointConfig { kind: EndpointKind::UdpIn { bind: loopback0(), max_peers: 8 }, signing_key_file: None }
}

fn gcs_heartbeat() -> MavMessage {
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        mavtype: MavType::MAV_TYPE_GCS,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        ..Default::default()
    })
}

fn command_long(command: MavCmd, params: [f32; 7]) -> MavMessage {
    MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
        param1: params[0],
        param2: params[1],
        param3: params[2],
        param4: params[3],
        param5: params[4],
        param6: params[5],
        param7: params[6],
        command,
        target_system: 1,
        target_component: 1,
        confirmation: 0,
    })
}

/// Waits for the vehicle's heartbeat and returns the address it came from.
async fn vehicle_address(gcs: &Peer) -> SocketAddr {
    let (hb, from) = gcs
        .recv_until(WAIT, |h, m| match m {
            MavMessage::HEARTBEAT(hb) if h.system_id == 1 && h.component_id == 1 => Some(hb.clone()),
            _ => None,
        })
        .await
        .expect("the vehicle's heartbeat reaches the ground-station address");
    assert_eq!(hb.mavtype, MavType::MAV_TYPE_QUADROTOR);
    assert_eq!(hb.autopilot, MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA);
    from
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ground_station_on_the_client_address_sees_the_vehicle_and_fetches_parameters() {
    let mut gcs = Peer::bind(255).await;
    let link = Harness::start(&[udp_out(gcs.addr())], 300, std::path::Path::new(".")).await;
    let vehicle = vehicle_address(&gcs).await;

    // MAVLink 1 inbound, as pymavlink speaks before it has heard MAVLink 2.
    gcs.version = MavlinkVersion::V1;
    gcs.send(vehicle, &gcs_heartbeat()).await;
    let started = Instant::now();
    gcs.send(
        vehicle,
        &MavMessage::PARAM_REQUEST_LIST(PARAM_REQUEST_LIST_DATA { target_system: 1, target_component: 1 }),
    )
    .await;
    let mut seen = std::collections::BTreeSet::new();
    gcs.recv_until(WAIT, |_, m| match m {
        MavMessage::PARAM_VALUE(p) => {
            seen.insert(p.param_index);
            (seen.len() == usize::from(p.param_count)).then_some(())
        }
        _ => None,
    })
    .await
    .expect("every parameter arrives");
    println!("figure: 300-parameter list over UDP loopback in {:?}", started.elapsed());

    gcs.version = MavlinkVersion::V2;
    let mut set =
        PARAM_SET_DATA { param_value: 42.0, target_system: 1, target_component: 1, ..Default::default() };
    set.param_id = "TEST_P4".into();
    set.param_type = MavParamType::MAV_PARAM_TYPE_REAL32;
    gcs.send(vehicle, &MavMessage::PARAM_SET(set)).await;
    let (value, _) = gcs
        .recv_until(WAIT, |_, m| match m {
            MavMessage::PARAM_VALUE(p)
                if p.param_id.to_str().is_ok_and(|id| id.trim_end_matches('\0') == "TEST_P4") =>
            {
                Some(p.param_value)
            }
            _ => None,
        })
        .await
        .expect("PARAM_VALUE answers PARAM_SET");
    assert_eq!(value, 42.0);
    let graph = link.graph.lock().expect("graph").clone();
    assert!(
        graph.iter().any(|g| matches!(g, ToGraph::Command(Command::Heartbeat { .. }))),
        "GCS heartbeat refreshes the data-link timer"
    );
    assert!(graph.iter().any(|g| matches!(g, ToGraph::Param(p) if p.name == "TEST_P4" && p.value == 42.0)));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn commands_are_acknowledged_and_unknown_ones_unsupported_at_once() {
    let mut gcs = Peer::bind(255).await;
    let link = Harness::start(&[udp_out(gcs.addr())], 0, std::path::Path::new(".")).await;
    let vehicle = vehicle_address(&gcs).await;

    gcs.send(vehicle, &command_long(MavCmd::MAV_CMD_DO_PARACHUTE, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])).await;
    // Answered by the link itself ("at once"): nothing goes to the graph to wait on.
    let commands_to_graph = || {
        link.graph
            .lock()
            .expect("graph")
            .iter()
            .filter(|g| matches!(g, ToGraph::Command(_) | ToGraph::Request { .. }))
            .count()
    };
    let ack = |cmd: MavCmd| {
        move |_: &mavlink::MavHeader, m: &MavMessage| match m {
            MavMessage::COMMAND_ACK(a) if a.command == cmd => Some(a.result),
            _ => None,
        }
    };
    let (r, _) = gcs.recv_until(WAIT, ack(MavCmd::MAV_CMD_DO_PARACHUTE)).await.expect("ack");
    assert_eq!(r, MavResult::MAV_RESULT_UNSUPPORTED);
    assert_eq!(commands_to_graph(), 0);

    // No commander in this test: the arm request goes to the graph and, unanswered, is DENIED.
    gcs.send(
        vehicle,
        &command_long(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
    )
    .await;
    let (r, _) = gcs.recv_until(WAIT, ack(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM)).await.expect("ack");
    assert_eq!(r, MavResult::MAV_RESULT_DENIED);
    let asked = |want: Command| {
        link.graph
            .lock()
            .expect("graph")
            .iter()
            .any(|g| matches!(g, ToGraph::Request { command, .. } if *command == want))
    };
    assert!(asked(Command::Arm));

    gcs.send(vehicle, &command_long(MavCmd::MAV_CMD_REQUEST_MESSAGE, [148.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]))
        .await;
    let (caps, _) = gcs
        .recv_until(WAIT, |_, m| match m {
            MavMessage::AUTOPILOT_VERSION(v) => Some(v.capabilities),
            _ => None,
        })
        .await
        .expect("AUTOPILOT_VERSION on request");
    assert!(caps.contains(MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_INT));
    assert!(caps.contains(MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MAVLINK2));
    assert!(caps.contains(MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_FTP));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
#[allow(deprecated, reason = "MISSION_SET_CURRENT is superseded but still sent by ground stations")]
async fn home_fence_and_mission_current_commands_reach_the_commander_or_are_refused_at_once() {
    let mut gcs = Peer::bind(255).await;
    let link = Harness::start(&[udp_out(gcs.addr())], 0, std::path::Path::new(".")).await;
    let vehicle = vehicle_address(&gcs).await;
    let ack = |cmd: MavCmd| {
        move |_: &mavlink::MavHeader, m: &MavMessage| match m {
            MavMessage::COMMAND_ACK(a) if a.command == cmd => Some(a.result),
            _ => None,
        }
    };
    // Refused by the link itself ("at once": nothing goes to the graph to wait on), each with the
    // result the spec gives it.
    let commands_to_graph = || {
        link.graph
            .lock()
            .expect("graph")
            .iter()
            .filter(|g| matches!(g, ToGraph::Command(_) | ToGraph::Request { .. }))
            .count()
    };
    let refused = [
        (
            MavCmd::MAV_CMD_DO_FENCE_ENABLE,
            [2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            MavResult::MAV_RESULT_UNSUPPORTED,
        ),
        (MavCmd::MAV_CMD_DO_SET_HOME, [0.0, 0.0, 0.0, 0.0, 91.0, 79.9, 20.0], MavResult::MAV_RESULT_DENIED),
        (
            MavCmd::MAV_CMD_DO_SET_MISSION_CURRENT,
            [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            MavResult::MAV_RESULT_FAILED,
        ),
    ];
    let forwarded = commands_to_graph();
    for (cmd, params, want) in refused {
        gcs.send(vehicle, &command_long(cmd, params)).await;
        let (r, _) = gcs.recv_until(WAIT, ack(cmd)).await.expect("ack");
        assert_eq!(r, want, "{cmd:?}");
        assert_eq!(commands_to_graph(), forwarded, "{cmd:?} refused by the link, not forwarded");
    }
    // MISSION_SET_CURRENT without a mission: a STATUSTEXT says why.
    let set = MISSION_SET_CURRENT_DATA { seq: 1, target_system: 1, target_component: 1 };
    gcs.send(vehicle, &MavMessage::MISSION_SET_CURRENT(set)).await;
    let (text, _) = gcs
        .recv_until(WAIT, |_, m| match m {
            MavMessage::STATUSTEXT(t) => {
                Some(t.text.to_str().unwrap_or_default().trim_end_matches('\0').to_owned())
            }
            _ => None,
        })
        .await
        .expect("STATUSTEXT");
    assert!(text.contains("Mission item 1 refused"), "{text}");
    // Valid ones go to the commander (here none answers: DENIED after the timeout).
    gcs.send(vehicle, &command_long(MavCmd::MAV_CMD_DO_FENCE_ENABLE, [0.0; 7])).await;
    gcs.send(vehicle, &command_long(MavCmd::MAV_CMD_DO_SET_HOME, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])).await;
    let (r, _) = gcs.recv_until(WAIT, ack(MavCmd::MAV_CMD_DO_SET_HOME)).await.expect("ack");
    assert_eq!(r, MavResult::MAV_RESULT_DENIED);
    let graph = link.graph.lock().expect("graph").clone();
    let asked = |want: Command| {
        graph.iter().any(|g| matches!(g, ToGraph::Request { command, .. } if *command == want))
    };
    assert!(asked(Command::SetGeofence { enabled: false }), "{graph:?}");
    assert!(asked(Command::SetHome { point: None }), "{graph:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_500_item_mission_uploads_and_downloads_identical() {
    let mut gcs = Peer::bind(255).await;
    let _link = Harness::start(&[udp_out(gcs.addr())], 0, std::path::Path::new(".")).await;
    let vehicle = vehicle_address(&gcs).await;
    let n: u16 = 500;
    let item = |seq: u16| MISSION_ITEM_INT_DATA {
        seq,
        command: if seq == 1 { MavCmd::MAV_CMD_NAV_TAKEOFF } else { MavCmd::MAV_CMD_NAV_WAYPOINT },
        frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
        x: 67_971_000 + i32::from(seq) * 10,
        y: 799_017_000 - i32::from(seq) * 10,
        z: 20.0 + f32::from(seq % 7),
        target_system: 1,
        target_component: 1,
        autocontinue: 1,
        mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
        ..Default::default()
    };
    let started = Instant::now();
    let count = MISSION_COUNT_DATA {
        count: n,
        target_system: 1,
        target_component: 1,
        mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
        opaque_id: 0,
    };
    gcs.send(vehicle, &MavMessage::MISSION_COUNT(count)).await;
    loop {
        let (next, _) = gcs
            .recv_until(WAIT, |_, m| match m {
                MavMessage::MISSION_REQUEST_INT(r) => Some(Ok(r.seq)),
                MavMessage::MISSION_ACK(a) => Some(Err(a.mavtype)),
                _ => None,
            })
            .await
            .expect("the vehicle drives the upload");
        match next {
            Ok(seq) => gcs.send(vehicle, &MavMessage::MISSION_ITEM_INT(item(seq))).await,
            Err(result) => {
                assert_eq!(result, MavMissionResult::MAV_MISSION_ACCEPTED);
                break;
            }
        }
    }
    println!("figure: 500-item mission upload over UDP loopback in {:?}", started.elapsed());

    let list = MISSION_REQUEST_LIST_DATA {
        target_system: 1,
        target_component: 1,
        mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
    };
    gcs.send(vehicle, &MavMessage::MISSION_REQUEST_LIST(list)).await;
    let (got, _) = gcs
        .recv_until(WAIT, |_, m| match m {
            MavMessage::MISSION_COUNT(c) => Some(c.count),
            _ => None,
        })
        .await
        .expect("count");
    assert_eq!(got, n);
    for seq in 0..n {
        let req = MISSION_REQUEST_INT_DATA {
            seq,
            target_system: 1,
            target_component: 1,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
        };
        gcs.send(vehicle, &MavMessage::MISSION_REQUEST_INT(req)).await;
        let (back, _) = gcs
            .recv_until(WAIT, |_, m| match m {
                MavMessage::MISSION_ITEM_INT(i) if i.seq == seq => Some(i.clone()),
                _ => None,
            })
            .await
            .expect("item");
        let want = item(seq);
        assert_eq!(
            (back.x, back.y, back.z, back.command, back.frame),
            (want.x, want.y, want.z, want.command, want.frame)
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn routing_between_peers_and_malformed_input() {
    let mut gcs = Peer::bind(255).await;
    let link = Harness::start(&[udp_out(gcs.addr()), udp_in()], 0, std::path::Path::new(".")).await;
    let server = link.endpoints[1].local_addr.expect("the UDP server's address");
    let vehicle = vehicle_address(&gcs).await;
    gcs.send(vehicle, &gcs_heartbeat()).await;

    let mut companion = Peer::bind(42).await;
    companion.socket.send_to(b"\xfd\x09garbage that is not mavlink \xfe\x05", server).await.expect("send");
    companion.send(server, &gcs_heartbeat()).await;
    // Addressed to the GCS: must reach it through the vehicle's router.
    let mut to_gcs = command_long(MavCmd::MAV_CMD_DO_SET_SERVO, [1.0; 7]);
    if let MavMessage::COMMAND_LONG(c) = &mut to_gcs {
        c.target_system = 255;
    }
    companion.send(server, &to_gcs).await;
    let (h, _) = gcs
        .recv_until(WAIT, |h, m| match m {
            MavMessage::COMMAND_LONG(c) if c.command == MavCmd::MAV_CMD_DO_SET_SERVO => Some(*h),
            _ => None,
        })
        .await
        .expect("routed to the GCS");
    assert_eq!(h.system_id, 42, "forwarded untouched");
    // The companion hears the GCS's broadcasts but never its own frames back.
    gcs.send(vehicle, &gcs_heartbeat()).await;
    let (sys, _) = companion
        .recv_until(WAIT, |h, m| {
            matches!(m, MavMessage::HEARTBEAT(_) if h.system_id == 255).then_some(h.system_id)
        })
        .await
        .expect("broadcast reaches the companion");
    assert_eq!(sys, 255);
    let echoed =
        companion.recv_until(Duration::from_millis(300), |h, _| (h.system_id == 42).then_some(())).await;
    assert!(echoed.is_none(), "a frame never goes back where it came from");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn with_signing_on_unsigned_commands_are_refused_and_signed_ones_served() {
    let dir = std::env::temp_dir().join(format!("kestrel-link-signing-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let key = [0x5a_u8; 32];
    std::fs::write(dir.join("key.bin"), key).expect("key file");
    std::fs::set_permissions(dir.join("key.bin"), std::os::unix::fs::PermissionsExt::from_mode(0o600))
        .expect("chmod 600 the key file");
    let mut gcs = Peer::bind(255).await;
    let endpoint = EndpointConfig {
        kind: EndpointKind::UdpOut { address: gcs.addr(), bind: None, per_instance: false },
        signing_key_file: Some("key.bin".into()),
    };
    let link = Harness::start(&[endpoint], 0, &dir).await;
    let vehicle = vehicle_address(&gcs).await;

    let long = command_long(MavCmd::MAV_CMD_DO_PARACHUTE, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    gcs.send(vehicle, &long).await;
    let ack = |_: &mavlink::MavHeader, m: &MavMessage| matches!(m, MavMessage::COMMAND_ACK(_)).then_some(());
    assert!(gcs.recv_until(Duration::from_millis(500), ack).await.is_none(), "unsigned command ignored");
    gcs.signing = Some(SigningData::from_config(SigningConfig::new(key, 0, true, false)));
    gcs.send(vehicle, &long).await;
    assert!(gcs.recv_until(WAIT, ack).await.is_some(), "signed command answered");
    let stats = link.hub.lock().expect("hub").link_stats();
    assert_eq!(stats[0].1.signing.unsigned_refused, 1, "{stats:?}");
    std::fs::remove_dir_all(&dir).ok();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_5000_msg_per_second_flood_does_not_stall_the_link() {
    let mut gcs = Peer::bind(255).await;
    let link = Harness::start(&[udp_out(gcs.addr()), udp_in()], 1, std::path::Path::new(".")).await;
    let server = link.endpoints[1].local_addr.expect("the UDP server's address");
    let vehicle = vehicle_address(&gcs).await;

    let mut flooder = Peer::bind(254).await;
    // The flood runs until every round trip is done, so each is answered *during* it.
    let flooding = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(true));
    let still_flooding = std::sync::Arc::clone(&flooding);
    let flood = tokio::spawn(async move {
        let sticks =
            MavMessage::MANUAL_CONTROL(MANUAL_CONTROL_DATA { target: 1, z: 500, ..Default::default() });
        let mut tick = tokio::time::interval(Duration::from_millis(10));
        let started = Instant::now();
        let mut sent = 0u32;
        while still_flooding.load(std::sync::atomic::Ordering::Acquire) {
            tick.tick().await;
            for _ in 0..50 {
                flooder.send(server, &sticks).await;
                sent += 1;
            }
        }
        (sent, started.elapsed())
    });
    let mut worst = Duration::ZERO;
    let mut read = PARAM_REQUEST_READ_DATA {
        param_index: 0,
        target_system: 1,
        target_component: 1,
        ..Default::default()
    };
    read.param_id = "TEST_P0".into();
    for _ in 0..15 {
        tokio::time::sleep(Duration::from_millis(100)).await;
        let t0 = Instant::now();
        gcs.send(vehicle, &MavMessage::PARAM_REQUEST_READ(read.clone())).await;
        gcs.recv_until(WAIT, |_, m| matches!(m, MavMessage::PARAM_VALUE(_)).then_some(()))
            .await
            .expect("answered during the flood");
        worst = worst.max(t0.elapsed());
    }
    flooding.store(false, std::sync::atomic::Ordering::Release);
    let (sent, flooded) = flood.await.expect("flood task");
    let delivered =
        link.graph.lock().expect("graph").iter().filter(|g| matches!(g, ToGraph::Manual(_))).count();
    println!(
        "figure: {sent} MANUAL_CONTROL in {flooded:?} ({:.0} msg/s), {delivered} reached the graph, worst PARAM_REQUEST_READ round trip {worst:?}",
        f64::from(sent) / flooded.as_secs_f64()
    );
    // Every read above was answered (within WAIT) while the flood went on.
}

fn udp_in_capped(max_peers: usize) -> EndpointConfig {
    EndpointConfig { kind: EndpointKind::UdpIn { bind: loopback0(), max_peers }, signing_key_file: None }
}

/// The server's peer counters as they stand.
fn peer_stats(link: &Harness) -> kestrel_link::transport::PeerStats {
    *link.endpoints[0].peer_stats.as_ref().expect("a UDP server has peer counters").lock().expect("stats")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_udp_server_answers_only_peers_that_sent_a_valid_frame() {
    let link = Harness::start(&[udp_in_capped(8)], 0, std::path::Path::new(".")).await;
    let server = link.endpoints[0].local_addr.expect("the UDP server's address");
    let stranger = Peer::bind(200).await;
    // Garbage, and a heartbeat with its checksum broken: neither makes a peer.
    let mut bad = Vec::new();
    let header = mavlink::MavHeader { system_id: 200, component_id: 190, sequence: 0 };
    mavlink::write_versioned_msg(&mut bad, MavlinkVersion::V2, header, &gcs_heartbeat()).expect("serialise");
    let last = bad.len() - 1;
    bad[last] ^= 0xff;
    stranger.socket.send_to(b"\xfd\x09 not mavlink at all", server).await.expect("send");
    stranger.socket.send_to(&bad, server).await.expect("send");
    let heard = stranger.recv_until(Duration::from_millis(1500), |_, _| Some(())).await;
    assert!(heard.is_none(), "the vehicle sent telemetry to an address that never sent a valid frame");
    let stats = peer_stats(&link);
    assert_eq!((stats.admitted, stats.unverified_datagrams), (0, 2), "{stats:?}");

    let mut gcs = Peer::bind(255).await;
    gcs.send(server, &gcs_heartbeat()).await;
    assert_eq!(vehicle_address(&gcs).await, server, "a valid heartbeat makes a peer that gets telemetry");
    assert_eq!(peer_stats(&link).admitted, 1);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_full_udp_server_refuses_newcomers_while_its_peers_are_live() {
    let link = Harness::start(&[udp_in_capped(1)], 0, std::path::Path::new(".")).await;
    let server = link.endpoints[0].local_addr.expect("the UDP server's address");
    let mut gcs = Peer::bind(255).await;
    gcs.send(server, &gcs_heartbeat()).await;
    vehicle_address(&gcs).await;

    let mut newcomer = Peer::bind(254).await;
    let started = Instant::now();
    while started.elapsed() < Duration::from_millis(1500) {
        newcomer.send(server, &gcs_heartbeat()).await;
        gcs.send(server, &gcs_heartbeat()).await;
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    let heard = newcomer.recv_until(Duration::from_millis(100), |_, _| Some(())).await;
    assert!(heard.is_none(), "a newcomer to a full table got frames");
    let stats = peer_stats(&link);
    assert_eq!(stats.admitted, 1, "{stats:?}");
    assert!(stats.refused_full >= 10, "{stats:?}");
    assert_eq!(stats.evicted, 0, "a live peer is never pushed out: {stats:?}");
    assert!(gcs.recv_until(WAIT, |h, _| (h.system_id == 1).then_some(())).await.is_some());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ftp_opens_the_parameter_file_for_the_requester_at_once() {
    let mut gcs = Peer::bind(255).await;
    let _link = Harness::start(&[udp_out(gcs.addr())], 0, std::path::Path::new(".")).await;
    let vehicle = vehicle_address(&gcs).await;
    // MAVProxy's first request for the parameter file: OpenFileRO (4), sequence 0, session 181.
    let path = b"@PARAM/param.pck?withdefaults=1";
    let mut payload = [0u8; 251];
    payload[2] = 181;
    payload[3] = 4;
    payload[4] = path.len() as u8;
    payload[12..12 + path.len()].copy_from_slice(path);
    let request =
        FILE_TRANSFER_PROTOCOL_DATA { target_network: 0, target_system: 1, target_component: 1, payload };
    gcs.send(vehicle, &MavMessage::FILE_TRANSFER_PROTOCOL(request)).await;
    let (ack, _) = gcs
        .recv_until(WAIT, |_, m| match m {
            MavMessage::FILE_TRANSFER_PROTOCOL(f) => Some(f.clone()),
            _ => None,
        })
        .await
        .expect("an FTP answer");
    // ACK (128) of OpenFileRO, size 4 (the file's size), sequence 1, the session echoed.
    let p = ack.payload;
    assert_eq!((p[0], p[1], p[2], p[3], p[4], p[5]), (1, 0, 181, 128, 4, 4));
    let size = u32::from_le_bytes([p[12], p[13], p[14], p[15]]);
    assert!(size >= 6, "at least param.pck's header: {size} bytes");
    assert_eq!((ack.target_system, ack.target_component), (255, 190), "to the requester");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_dropped_mission_item_is_requested_again_and_a_10000_item_mission_refused() {
    let mut gcs = Peer::bind(255).await;
    let _link = Harness::start(&[udp_out(gcs.addr())], 0, std::path::Path::new(".")).await;
    let vehicle = vehicle_address(&gcs).await;
    let count = |count| {
        MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
            count,
            target_system: 1,
            target_component: 1,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
            opaque_id: 0,
        })
    };
    let next = |_: &mavlink::MavHeader, m: &MavMessage| match m {
        MavMessage::MISSION_REQUEST_INT(r) => Some(Ok(r.seq)),
        MavMessage::MISSION_ACK(a) => Some(Err(a.mavtype)),
        _ => None,
    };
    gcs.send(vehicle, &count(10_000)).await;
    let (refused, _) = gcs.recv_until(WAIT, next).await.expect("an answer to 10 000 items");
    assert_eq!(refused, Err(MavMissionResult::MAV_MISSION_NO_SPACE));

    let item = |seq: u16| {
        MavMessage::MISSION_ITEM_INT(MISSION_ITEM_INT_DATA {
            seq,
            command: MavCmd::MAV_CMD_NAV_WAYPOINT,
            frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
            x: 67_971_000 + i32::from(seq) * 100,
            y: 799_017_000,
            z: 10.0,
            target_system: 1,
            target_component: 1,
            autocontinue: 1,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
            ..Default::default()
        })
    };
    gcs.send(vehicle, &count(3)).await;
    assert_eq!(gcs.recv_until(WAIT, next).await.map(|r| r.0), Some(Ok(0)));
    gcs.send(vehicle, &item(0)).await;
    assert_eq!(gcs.recv_until(WAIT, next).await.map(|r| r.0), Some(Ok(1)));
    // Item 1 is "lost": the vehicle asks for it again after its timeout, not before.
    let dropped = Instant::now();
    assert_eq!(gcs.recv_until(WAIT, next).await.map(|r| r.0), Some(Ok(1)));
    let waited = dropped.elapsed();
    assert!(waited >= Duration::from_millis(1300), "re-requested after only {waited:?}");
    for seq in 1..3 {
        gcs.send(vehicle, &item(seq)).await;
        let want = if seq == 2 { Err(MavMissionResult::MAV_MISSION_ACCEPTED) } else { Ok(seq + 1) };
        assert_eq!(gcs.recv_until(WAIT, next).await.map(|r| r.0), Some(want));
    }
}
