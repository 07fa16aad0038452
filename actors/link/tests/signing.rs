//! MAVLink 2 signing over real UDP endpoints, against frames signed by the `mavlink` crate's own
//! signer (not this crate's): one replay table for every endpoint, a new UDP peer's first
//! signed frame served, unsigned RADIO_STATUS taken (and nothing else unsigned), SETUP_SIGNING
//! refused off serial, and key files others may read refused.

#[allow(dead_code, reason = "shared with the other test binaries; this one reads no graph output")]
mod common;
#[path = "common/peer.rs"]
#[allow(dead_code, reason = "shared with the other test binaries")]
mod peer;

use std::net::{Ipv4Addr, SocketAddr};
use std::os::unix::fs::PermissionsExt;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::Harness;
use kestrel_link::config::{EndpointConfig, EndpointKind};
use kestrel_link::hub::{Hub, LinkStats};
use kestrel_link::services::params::ParamTable;
use kestrel_link::transport::{EndpointError, KeyError, Shared, open_all};
use kestrel_link::vehicle::Vehicle;
use mavlink::dialects::ardupilotmega::*;
use mavlink::{MavHeader, MavlinkVersion, SigningConfig, SigningData};
use peer::Peer;
use tokio_util::sync::CancellationToken;

const WAIT: Duration = Duration::from_secs(3);
const KEY: [u8; 32] = [0x5a; 32];

/// A temp dir holding `key.bin` (mode `mode`).
fn key_dir(name: &str, mode: u32) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kestrel-link-signing-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    std::fs::write(dir.join("key.bin"), KEY).expect("key file");
    std::fs::set_permissions(dir.join("key.bin"), std::fs::Permissions::from_mode(mode)).expect("chmod");
    dir
}

fn signed(kind: EndpointKind) -> EndpointConfig {
    EndpointConfig { kind, signing_key_file: Some("key.bin".into()) }
}

fn udp_in() -> EndpointKind {
    EndpointKind::UdpIn { bind: (Ipv4Addr::LOCALHOST, 0).into(), max_peers: 4 }
}

fn udp_out(to: SocketAddr) -> EndpointKind {
    EndpointKind::UdpOut { address: to, bind: None, per_instance: false }
}

fn parachute() -> MavMessage {
    MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
        command: MavCmd::MAV_CMD_DO_PARACHUTE,
        param1: 1.0,
        target_system: 1,
        target_component: 1,
        ..Default::default()
    })
}

/// `msg` as a ground station (255/190) signing with `KEY` on its link 0 would send it.
fn gcs_bytes(signer: &SigningData, seq: u8, msg: &MavMessage) -> Vec<u8> {
    let header = MavHeader { system_id: 255, component_id: 190, sequence: seq };
    let mut buf = Vec::new();
    mavlink::write_versioned_msg_signed(&mut buf, MavlinkVersion::V2, header, msg, Some(signer))
        .expect("sign");
    buf
}

fn ack(_: &MavHeader, m: &MavMessage) -> Option<()> {
    matches!(m, MavMessage::COMMAND_ACK(_)).then_some(())
}

fn stats_of(link: &Harness, prefix: &str) -> LinkStats {
    let all = link.hub.lock().expect("hub").link_stats();
    all.iter()
        .find(|(n, _)| n.starts_with(prefix))
        .map(|(_, s)| *s)
        .unwrap_or_else(|| panic!("{prefix}: {all:?}"))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_new_udp_peers_first_signed_frame_is_served() {
    let dir = key_dir("first-frame", 0o600);
    let link = Harness::start(&[signed(udp_in())], 0, &dir).await;
    let server = link.endpoints[0].local_addr.expect("bound");
    let gcs = Peer::bind(255).await;
    let signer = SigningData::from_config(SigningConfig::new(KEY, 0, true, false));
    gcs.socket.send_to(&gcs_bytes(&signer, 0, &parachute()), server).await.expect("send");
    assert!(gcs.recv_until(WAIT, ack).await.is_some(), "the frame that admitted the peer is answered");
    let stats = stats_of(&link, "udp peer");
    println!("figure: new UDP peer's first signed frame: {:?}", stats.signing);
    assert_eq!((stats.signing.signed_accepted, stats.signing.replays), (1, 0), "{stats:?}");
    std::fs::remove_dir_all(&dir).ok();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_signed_frame_captured_on_one_endpoint_is_a_replay_on_another() {
    let dir = key_dir("replay", 0o600);
    let gcs = Peer::bind(255).await;
    let attacker = Peer::bind(77).await;
    let link =
        Harness::start(&[signed(udp_out(gcs.addr())), signed(udp_out(attacker.addr()))], 0, &dir).await;
    let to_gcs = link.endpoints[0].local_addr.expect("bound");
    let to_attacker = link.endpoints[1].local_addr.expect("bound");
    let signer = SigningData::from_config(SigningConfig::new(KEY, 0, true, false));
    let captured = gcs_bytes(&signer, 0, &parachute());
    gcs.socket.send_to(&captured, to_gcs).await.expect("send");
    assert!(gcs.recv_until(WAIT, ack).await.is_some(), "the genuine command is answered");
    // The same bytes, heard on the air, sent to the other endpoint.
    attacker.socket.send_to(&captured, to_attacker).await.expect("send");
    assert!(attacker.recv_until(Duration::from_millis(700), ack).await.is_none(), "the replay is not obeyed");
    let replayed_on = stats_of(&link, &format!("udp client -> {}", attacker.addr()));
    println!("figure: replay on the second endpoint: {:?}", replayed_on.signing);
    assert_eq!(replayed_on.signing.replays, 1, "{replayed_on:?}");
    assert_eq!(replayed_on.frames_in, 0, "{replayed_on:?}");
    // Newer frames of the genuine ground station are still taken.
    gcs.socket.send_to(&gcs_bytes(&signer, 1, &parachute()), to_gcs).await.expect("send");
    assert!(gcs.recv_until(WAIT, ack).await.is_some());
    std::fs::remove_dir_all(&dir).ok();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn on_a_signed_link_unsigned_radio_status_thins_telemetry_and_other_unsigned_frames_are_refused() {
    let dir = key_dir("radio-status", 0o600);
    let radio = Peer::bind(51).await;
    let link = Harness::start(&[signed(udp_out(radio.addr()))], 0, &dir).await;
    let to_radio = link.endpoints[0].local_addr.expect("bound");
    let send = |msg: MavMessage| {
        let mut buf = Vec::new();
        let header = MavHeader { system_id: 51, component_id: 68, sequence: 0 };
        mavlink::write_versioned_msg(&mut buf, MavlinkVersion::V2, header, &msg).expect("serialise");
        buf
    };
    radio
        .socket
        .send_to(&send(MavMessage::HEARTBEAT(HEARTBEAT_DATA::default())), to_radio)
        .await
        .expect("send");
    let status = MavMessage::RADIO_STATUS(RADIO_STATUS_DATA { txbuf: 10, rssi: 200, ..Default::default() });
    radio.socket.send_to(&send(status), to_radio).await.expect("send");
    tokio::time::sleep(Duration::from_millis(300)).await;
    let before = stats_of(&link, "udp client").thinned;
    tokio::time::sleep(Duration::from_secs(1)).await;
    let stats = stats_of(&link, "udp client");
    println!("figure: signed link, unsigned frames: {:?}, thinned {}", stats.signing, stats.thinned);
    assert_eq!((stats.signing.unsigned_radio_status, stats.signing.unsigned_refused), (1, 1), "{stats:?}");
    assert!(stats.thinned > before, "10 % buffer free thins telemetry: {stats:?}");
    std::fs::remove_dir_all(&dir).ok();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn setup_signing_over_udp_is_refused_with_a_statustext_and_the_key_stays() {
    let dir = key_dir("setup-udp", 0o600);
    let gcs = Peer::bind(255).await;
    let link = Harness::start(&[signed(udp_out(gcs.addr()))], 0, &dir).await;
    let to_gcs = link.endpoints[0].local_addr.expect("bound");
    let signer = SigningData::from_config(SigningConfig::new(KEY, 0, true, false));
    let setup = MavMessage::SETUP_SIGNING(SETUP_SIGNING_DATA {
        initial_timestamp: 1,
        target_system: 1,
        target_component: 1,
        secret_key: [0x11; 32],
    });
    gcs.socket.send_to(&gcs_bytes(&signer, 0, &setup), to_gcs).await.expect("send");
    let text = gcs
        .recv_until(WAIT, |_, m| match m {
            MavMessage::STATUSTEXT(s) => {
                let t = s.text.to_str().unwrap_or_default().trim_end_matches('\0').to_owned();
                t.contains("SETUP_SIGNING").then_some(t)
            }
            _ => None,
        })
        .await
        .map(|(t, _)| t);
    assert_eq!(text.as_deref(), Some("SETUP_SIGNING refused: not a serial link"));
    assert_eq!(std::fs::read(dir.join("key.bin")).expect("key"), KEY, "the key file is unchanged");
    // The old key still commands the vehicle.
    gcs.socket.send_to(&gcs_bytes(&signer, 1, &parachute()), to_gcs).await.expect("send");
    assert!(gcs.recv_until(WAIT, ack).await.is_some());
    std::fs::remove_dir_all(&dir).ok();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_key_file_others_may_read_is_refused_naming_the_file_and_its_mode() {
    let dir = key_dir("mode", 0o644);
    let table = ParamTable::new(Vec::new()).expect("table");
    let hub = Arc::new(Mutex::new(Hub::new(Vehicle::new(1, table, Duration::from_secs(5)))));
    let shutdown = CancellationToken::new();
    let shared = Shared {
        hub,
        clock: Arc::new(common::WallClock(Instant::now())),
        shutdown: shutdown.clone(),
        graph: Arc::new(|_| {}),
        param_writer: None,
        endpoint: 0,
    };
    let result = open_all(&[signed(udp_in())], &dir, &shared).await;
    shutdown.cancel();
    let err = result.expect_err("a 0644 key is refused");
    let text = err.to_string();
    println!("figure: {text}");
    assert!(matches!(err, EndpointError::SigningKey(KeyError::Permissions { mode: 0o644, .. })), "{err:?}");
    assert!(text.contains(&dir.join("key.bin").display().to_string()) && text.contains("0644"), "{text}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The text of every STATUSTEXT in `bytes`.
fn statustexts(bytes: &[u8]) -> Vec<String> {
    let mut frames = Vec::new();
    kestrel_link::frame::FrameParser::new().push(bytes, &mut frames);
    frames
        .iter()
        .filter_map(|f| match f.decode() {
            Ok(MavMessage::STATUSTEXT(s)) => {
                Some(s.text.to_str().unwrap_or_default().trim_end_matches('\0').to_owned())
            }
            _ => None,
        })
        .collect()
}

/// Reads `port` until a frame satisfies `pick` or `window` passes.
async fn read_until<T>(
    port: &mut tokio_serial::SerialStream,
    window: Duration,
    mut pick: impl FnMut(&[u8]) -> Option<T>,
) -> Option<T> {
    use tokio::io::AsyncReadExt;
    let deadline = tokio::time::Instant::now() + window;
    let mut seen = Vec::new();
    let mut buf = [0u8; 1024];
    while let Ok(Ok(n)) = tokio::time::timeout_at(deadline, port.read(&mut buf)).await {
        seen.extend_from_slice(&buf[..n]);
        if let Some(t) = pick(&seen) {
            return Some(t);
        }
    }
    None
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn setup_signing_over_serial_installs_the_key_for_good_and_the_old_key_stops_working() {
    use tokio::io::AsyncWriteExt;
    use tokio_serial::SerialPort;
    let dir = key_dir("setup-serial", 0o600);
    let (mut radio, slave) = tokio_serial::SerialStream::pair().expect("pseudo-terminal pair");
    let device = slave.name().expect("the slave side has a path");
    drop(slave);
    let endpoint = signed(EndpointKind::Serial { device: device.into(), baud: 57_600, flow_control: false });
    let link = Harness::start(&[endpoint], 0, &dir).await;
    let old = SigningData::from_config(SigningConfig::new(KEY, 0, true, false));
    let new_key = [0x3c; 32];
    let setup = MavMessage::SETUP_SIGNING(SETUP_SIGNING_DATA {
        initial_timestamp: 0,
        target_system: 1,
        target_component: 1,
        secret_key: new_key,
    });
    radio.write_all(&gcs_bytes(&old, 0, &setup)).await.expect("write");
    let installed =
        read_until(&mut radio, WAIT, |b| statustexts(b).into_iter().find(|t| t.contains("Signing key")))
            .await;
    assert_eq!(installed.as_deref(), Some("Signing key installed"));
    let stored = std::fs::read_to_string(dir.join("key.bin")).expect("key file");
    assert_eq!(stored.trim(), "3c".repeat(32), "the new key is in the key file");
    let mode = std::fs::metadata(dir.join("key.bin")).expect("meta").permissions().mode() & 0o777;
    assert_eq!(mode, 0o600);

    let is_ack = |b: &[u8]| {
        let mut frames = Vec::new();
        kestrel_link::frame::FrameParser::new().push(b, &mut frames);
        frames.iter().any(|f| matches!(f.decode(), Ok(MavMessage::COMMAND_ACK(_)))).then_some(())
    };
    radio.write_all(&gcs_bytes(&old, 1, &parachute())).await.expect("write");
    assert!(
        read_until(&mut radio, Duration::from_millis(700), is_ack).await.is_none(),
        "the old key is refused"
    );
    let new = SigningData::from_config(SigningConfig::new(new_key, 0, true, false));
    radio.write_all(&gcs_bytes(&new, 2, &parachute())).await.expect("write");
    assert!(read_until(&mut radio, WAIT, is_ack).await.is_some(), "the new key commands the vehicle");
    let stats = stats_of(&link, "serial");
    println!("figure: SETUP_SIGNING over serial: {:?}", stats.signing);
    assert_eq!(stats.signing.bad_signature, 1, "{stats:?}");
    std::fs::remove_dir_all(&dir).ok();
}
