//! UDP endpoints. The client sends to a fixed address (where a ground station listens) from an
//! ephemeral port and hears replies there; the server answers every peer that talks to it,
//! each peer a link of its own, so routing never echoes a peer's frames back to it.

use std::collections::HashMap;
use std::net::{Ipv4Addr, SocketAddr};
use std::sync::Arc;
use std::time::Duration;

use mavlink::SigningData;
use tokio::net::UdpSocket;
use tokio::time::Instant;

use super::{EndpointError, OpenEndpoint, Shared};
use crate::frame::FrameParser;
use crate::hub::Tx;
use crate::router::LinkId;

/// Largest datagram we read (MAVLink frames are at most 280 bytes; several may share one).
const DATAGRAM: usize = 65_536;

/// A server peer silent this long (wall clock) is forgotten, as a client that reconnects from a
/// new port would otherwise leave its old address collecting telemetry forever.
const PEER_TIMEOUT: Duration = Duration::from_secs(30);

/// Opens the UDP client endpoint towards `address`.
pub async fn open_client(
    address: SocketAddr,
    signing: Option<Arc<SigningData>>,
    shared: &Shared,
) -> Result<OpenEndpoint, EndpointError> {
    let bind: SocketAddr = if address.ip().is_loopback() {
        (Ipv4Addr::LOCALHOST, 0).into()
    } else {
        (Ipv4Addr::UNSPECIFIED, 0).into()
    };
    let socket = bind_socket(bind, "UDP client").await?;
    let local = socket.local_addr().ok();
    let id = shared.hub().add_link(
        format!("udp client -> {address}"),
        Tx::Udp { socket: Arc::clone(&socket), peer: address },
        signing,
    );
    let shared = shared.clone();
    tokio::spawn(async move {
        let mut parser = FrameParser::new();
        let mut buf = vec![0u8; DATAGRAM];
        loop {
            let received = tokio::select! {
                _ = shared.shutdown.cancelled() => break,
                r = socket.recv_from(&mut buf) => r,
            };
            // ICMP "port unreachable" while no ground station listens surfaces here: keep going.
            let Ok((n, _)) = received else { continue };
            feed(&shared, id, &mut parser, &buf[..n]);
        }
    });
    Ok(OpenEndpoint { name: format!("udp client -> {address}"), local_addr: local })
}

/// Opens the UDP server endpoint on `bind`.
pub async fn open_server(
    bind: SocketAddr,
    signing: Option<Arc<SigningData>>,
    shared: &Shared,
) -> Result<OpenEndpoint, EndpointError> {
    let socket = bind_socket(bind, "UDP server").await?;
    let local = socket.local_addr().ok();
    let shared = shared.clone();
    tokio::spawn(async move {
        let mut peers: HashMap<SocketAddr, (LinkId, FrameParser, Instant)> = HashMap::new();
        let mut buf = vec![0u8; DATAGRAM];
        let mut expiry = tokio::time::interval(PEER_TIMEOUT / 3);
        loop {
            let received = tokio::select! {
                _ = shared.shutdown.cancelled() => break,
                _ = expiry.tick() => {
                    peers.retain(|_, (id, _, heard)| {
                        let alive = heard.elapsed() < PEER_TIMEOUT;
                        if !alive {
                            shared.hub().remove_link(*id);
                        }
                        alive
                    });
                    continue;
                }
                r = socket.recv_from(&mut buf) => r,
            };
            let Ok((n, peer)) = received else { continue };
            let (id, parser, heard) = peers.entry(peer).or_insert_with(|| {
                let tx = Tx::Udp { socket: Arc::clone(&socket), peer };
                let id = shared.hub().add_link(format!("udp peer {peer}"), tx, signing.clone());
                (id, FrameParser::new(), Instant::now())
            });
            *heard = Instant::now();
            feed(&shared, *id, parser, &buf[..n]);
        }
    });
    Ok(OpenEndpoint { name: format!("udp server {bind}"), local_addr: local })
}

async fn bind_socket(addr: SocketAddr, what: &'static str) -> Result<Arc<UdpSocket>, EndpointError> {
    UdpSocket::bind(addr).await.map(Arc::new).map_err(|source| EndpointError::Bind { what, addr, source })
}

fn feed(shared: &Shared, id: LinkId, parser: &mut FrameParser, datagram: &[u8]) {
    let mut frames = Vec::new();
    parser.push(datagram, &mut frames);
    shared.handle_frames(id, &frames);
}
