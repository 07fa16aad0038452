//! The serial endpoint (a SiK radio's port) over a pseudo-terminal pair: a peer on the master
//! side speaks MAVLink 1 at 57600 baud; RADIO_STATUS with a filling buffer thins telemetry.

mod common;

use std::time::Duration;

use common::Harness;
use kestrel_link::config::{EndpointConfig, EndpointKind};
use kestrel_link::frame::FrameParser;
use kestrel_link::services::ToGraph;
use kestrel_proto::messages::Command;
use mavlink::dialects::ardupilotmega::*;
use mavlink::{MavHeader, MavlinkVersion};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_serial::{SerialPort, SerialStream};

fn frame(version: MavlinkVersion, system_id: u32, seq: u8, msg: &MavMessage) -> Vec<u8> {
    let mut buf = Vec::new();
    let header = MavHeader { system_id, component_id: 190, sequence: seq };
    mavlink::write_versioned_msg(&mut buf, version, header, msg).expect("serialise");
    buf
}

/// Reads from `port` for `window`, returning every decoded message.
async fn read_for(port: &mut SerialStream, window: Duration) -> Vec<MavMessage> {
    let mut parser = FrameParser::new();
    let mut frames = Vec::new();
    let mut buf = [0u8; 1024];
    let deadline = tokio::time::Instant::now() + window;
    while let Ok(Ok(n)) = tokio::time::timeout_at(deadline, port.read(&mut buf)).await {
        parser.push(&buf[..n], &mut frames);
    }
    frames.iter().filter_map(|f| f.decode().ok()).collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_radio_link_serves_mavlink_1_and_thins_telemetry_when_its_buffer_fills() {
    let (mut radio, slave) = SerialStream::pair().expect("pseudo-terminal pair");
    let device = slave.name().expect("the slave side has a path");
    drop(slave);
    let endpoint = EndpointConfig {
        kind: EndpointKind::Serial { device: device.into(), baud: 57_600, flow_control: false },
        signing_key_file: None,
    };
    let link = Harness::start(&[endpoint], 3, std::path::Path::new(".")).await;

    let gcs_hb =
        MavMessage::HEARTBEAT(HEARTBEAT_DATA { mavtype: MavType::MAV_TYPE_GCS, ..Default::default() });
    let mut read = PARAM_REQUEST_READ_DATA {
        param_index: -1,
        target_system: 1,
        target_component: 1,
        ..Default::default()
    };
    read.param_id = "TEST_P2".into();
    let mut bytes = frame(MavlinkVersion::V1, 255, 0, &gcs_hb);
    bytes.extend(frame(MavlinkVersion::V1, 255, 1, &MavMessage::PARAM_REQUEST_READ(read)));
    radio.write_all(&bytes).await.expect("write");
    let heard = read_for(&mut radio, Duration::from_millis(1500)).await;
    assert!(
        heard
            .iter()
            .any(|m| matches!(m, MavMessage::HEARTBEAT(h) if h.mavtype == MavType::MAV_TYPE_QUADROTOR))
    );
    assert!(heard.iter().any(|m| matches!(m, MavMessage::PARAM_VALUE(p) if p.param_index == 2)), "{heard:?}");
    assert!(
        link.graph
            .lock()
            .expect("graph")
            .iter()
            .any(|g| matches!(g, ToGraph::Command(Command::Heartbeat { .. })))
    );
    assert!(link.endpoints[0].name.starts_with("serial "), "{:?}", link.endpoints);

    // SiK radios report their free transmit buffer (%) as RADIO_STATUS from system 51.
    let status =
        |txbuf| MavMessage::RADIO_STATUS(RADIO_STATUS_DATA { txbuf, rssi: 200, ..Default::default() });
    radio.write_all(&frame(MavlinkVersion::V1, 51, 2, &status(10))).await.expect("write");
    tokio::time::sleep(Duration::from_millis(200)).await;
    let thinned_before = link.hub.lock().expect("hub").link_stats()[0].1.thinned;
    let _ = read_for(&mut radio, Duration::from_secs(1)).await;
    let stats = link.hub.lock().expect("hub").link_stats()[0].1;
    assert!(stats.thinned > thinned_before, "telemetry thinned with 10 % buffer free: {stats:?}");
    assert_eq!(stats.send_dropped, 0, "{stats:?}");
}

/// `socat` joining two pseudo-terminals linked at `dir/radio` (the vehicle's side) and
/// `dir/gcs`, once both links exist.
fn socat(dir: &std::path::Path) -> std::process::Child {
    for side in ["radio", "gcs"] {
        let _ = std::fs::remove_file(dir.join(side));
    }
    let pty = |side: &str| format!("pty,raw,echo=0,link={}", dir.join(side).display());
    let child = std::process::Command::new("socat")
        .args([pty("radio"), pty("gcs")])
        .stdin(std::process::Stdio::null())
        .spawn()
        .expect("socat (Debian package socat)");
    let deadline = std::time::Instant::now() + Duration::from_secs(5);
    while !(dir.join("radio").exists() && dir.join("gcs").exists()) {
        assert!(std::time::Instant::now() < deadline, "socat made no pseudo-terminals");
        std::thread::sleep(Duration::from_millis(10));
    }
    child
}

/// Writes a ground-station heartbeat every 100 ms until the vehicle answers with any frame;
/// the time that took, or `None` after `limit`.
async fn first_answer(gcs: &mut SerialStream, limit: Duration) -> Option<Duration> {
    let started = std::time::Instant::now();
    let hb = MavMessage::HEARTBEAT(HEARTBEAT_DATA { mavtype: MavType::MAV_TYPE_GCS, ..Default::default() });
    while started.elapsed() < limit {
        gcs.write_all(&frame(MavlinkVersion::V2, 255, 0, &hb)).await.ok()?;
        if !read_for(gcs, Duration::from_millis(100)).await.is_empty() {
            return Some(started.elapsed());
        }
    }
    None
}

fn open_gcs(path: &std::path::Path) -> SerialStream {
    let path = path.to_string_lossy().into_owned();
    tokio_serial::SerialPortBuilderExt::open_native_async(tokio_serial::new(path, 57_600))
        .expect("open the gcs side")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_serial_link_that_disappears_carries_traffic_again_when_it_returns() {
    let dir = std::env::temp_dir().join(format!("kestrel-serial-reopen-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let mut first = socat(&dir);
    let endpoint = EndpointConfig {
        kind: EndpointKind::Serial { device: dir.join("radio"), baud: 57_600, flow_control: false },
        signing_key_file: None,
    };
    let link = Harness::start(&[endpoint], 0, &dir).await;
    let mut gcs = open_gcs(&dir.join("gcs"));
    assert!(first_answer(&mut gcs, Duration::from_secs(3)).await.is_some(), "the radio link works");

    // The USB radio is unplugged: its device goes away, and the link with it.
    first.kill().expect("kill socat");
    first.wait().expect("reap socat");
    drop(gcs);
    let deadline = std::time::Instant::now() + Duration::from_secs(3);
    while !link.hub.lock().expect("hub").link_stats().is_empty() {
        assert!(std::time::Instant::now() < deadline, "the link outlived its device");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    // Unplugged for a while (the reopening back-off grows to its maximum), then back.
    tokio::time::sleep(Duration::from_secs(2)).await;
    let mut second = socat(&dir);
    let mut gcs = open_gcs(&dir.join("gcs"));
    let back = first_answer(&mut gcs, Duration::from_secs(5)).await;
    second.kill().ok();
    second.wait().ok();
    std::fs::remove_dir_all(&dir).ok();
    let back = back.expect("the link carries traffic again");
    println!(
        "figure: serial link carried traffic again {:.2} s after the device returned",
        back.as_secs_f64()
    );
    assert!(back < Duration::from_secs(2), "{back:?}");
}
