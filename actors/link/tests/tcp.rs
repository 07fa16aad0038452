//! The TCP server endpoint: each connection is a link; frames from one client reach another,
//! and a closed connection is forgotten.

mod common;

use std::net::{Ipv4Addr, SocketAddr};
use std::time::Duration;

use common::Harness;
use kestrel_link::config::{EndpointConfig, EndpointKind};
use kestrel_link::frame::FrameParser;
use kestrel_link::services::ToGraph;
use kestrel_proto::messages::Command;
use mavlink::dialects::ardupilotmega::*;
use mavlink::{MavHeader, MavlinkVersion};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

fn frame(system_id: u32, msg: &MavMessage) -> Vec<u8> {
    let mut buf = Vec::new();
    let header = MavHeader { system_id, component_id: 190, sequence: 0 };
    mavlink::write_versioned_msg(&mut buf, MavlinkVersion::V2, header, msg).expect("serialise");
    buf
}

/// Reads until `pick` matches a message from `system_id`, or 3 s pass.
async fn read_until(stream: &mut TcpStream, system_id: u32, pick: impl Fn(&MavMessage) -> bool) -> bool {
    let mut parser = FrameParser::new();
    let mut frames = Vec::new();
    let mut buf = [0u8; 4096];
    let deadline = tokio::time::Instant::now() + Duration::from_secs(3);
    while let Ok(Ok(n)) = tokio::time::timeout_at(deadline, stream.read(&mut buf)).await {
        if n == 0 {
            return false;
        }
        parser.push(&buf[..n], &mut frames);
        if frames.drain(..).any(|f| f.system_id == system_id && f.decode().is_ok_and(|m| pick(&m))) {
            return true;
        }
    }
    false
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tcp_clients_are_served_and_routed_to_each_other() {
    let bind: SocketAddr = (Ipv4Addr::LOCALHOST, 0).into();
    let endpoint = EndpointConfig { kind: EndpointKind::TcpIn { bind }, signing_key_file: None };
    let link = Harness::start(&[endpoint], 2, std::path::Path::new(".")).await;
    let server = link.endpoints[0].local_addr.expect("bound");

    let mut gcs = TcpStream::connect(server).await.expect("connect");
    let mut companion = TcpStream::connect(server).await.expect("connect");
    let list =
        MavMessage::PARAM_REQUEST_LIST(PARAM_REQUEST_LIST_DATA { target_system: 1, target_component: 1 });
    let gcs_hb =
        MavMessage::HEARTBEAT(HEARTBEAT_DATA { mavtype: MavType::MAV_TYPE_GCS, ..Default::default() });
    let mut bytes = frame(255, &gcs_hb);
    bytes.extend(frame(255, &list));
    gcs.write_all(&bytes).await.expect("write");
    assert!(read_until(&mut gcs, 1, |m| matches!(m, MavMessage::PARAM_VALUE(p) if p.param_index == 1)).await);

    let hb = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        mavtype: MavType::MAV_TYPE_ONBOARD_CONTROLLER,
        ..Default::default()
    });
    companion.write_all(&frame(42, &hb)).await.expect("write");
    assert!(
        read_until(&mut gcs, 42, |m| matches!(m, MavMessage::HEARTBEAT(_))).await,
        "routed between clients"
    );

    // The graph side is fed from the endpoint task: give a loaded machine a moment.
    let mut heard = false;
    for _ in 0..100 {
        heard = link
            .graph
            .lock()
            .expect("graph")
            .iter()
            .any(|g| matches!(g, ToGraph::Command(Command::Heartbeat { .. })));
        if heard {
            break;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    assert!(heard, "the GCS heartbeat reached the graph");
    drop(companion);
    tokio::time::sleep(Duration::from_millis(200)).await;
    assert_eq!(link.hub.lock().expect("hub").link_stats().len(), 1, "the closed connection is forgotten");
}
