//! UDP endpoints. The client sends to a fixed address (where a ground station listens) from an
//! ephemeral port and hears replies there; the server answers every peer that has sent it a
//! valid frame (see [`super::udp_peers`]), each peer a link of its own, so routing never echoes
//! a peer's frames back to it. A client with a fixed local port is both, as PX4 SITL's ports
//! are: it sends to its address from the start and answers whoever else talks to that port.

use std::net::{Ipv4Addr, SocketAddr};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tokio::net::UdpSocket;

use super::udp_peers::{Admission, PeerStats, PeerTable};
use super::{EndpointError, LinkSigning, OpenEndpoint, Shared, Verdict};
use crate::frame::FrameParser;
use crate::hub::Tx;
use crate::router::LinkId;
use crate::station::Station;

/// Largest datagram we read (MAVLink frames are at most 280 bytes; several may share one).
const DATAGRAM: usize = 65_536;

/// A server peer silent this long (wall clock) is forgotten, as a client that reconnects from a
/// new port would otherwise leave its old address collecting telemetry forever.
const PEER_TIMEOUT: Duration = Duration::from_secs(30);

/// Peers a client with a fixed local port answers besides its own address.
const CLIENT_EXTRA_PEERS: usize = 8;

/// Opens the UDP client endpoint towards `address`: from an ephemeral port, or from `bind` as a
/// server that always has `address` for a peer.
pub async fn open_client<S: Station>(
    address: SocketAddr,
    bind: Option<SocketAddr>,
    signing: Option<LinkSigning>,
    shared: &Shared<S>,
) -> Result<OpenEndpoint, EndpointError> {
    if let Some(bind) = bind {
        return serve(bind, CLIENT_EXTRA_PEERS, Some(address), signing, shared).await;
    }
    let bind: SocketAddr = if address.ip().is_loopback() {
        (Ipv4Addr::LOCALHOST, 0).into()
    } else {
        (Ipv4Addr::UNSPECIFIED, 0).into()
    };
    let endpoint = shared.endpoint;
    let socket = bind_socket(bind, "UDP client").await?;
    let local = socket.local_addr().ok();
    let id = shared.add_link(
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
    Ok(OpenEndpoint {
        name: format!("udp client -> {address}"),
        endpoint,
        local_addr: local,
        peer_stats: None,
    })
}

/// Opens the UDP server endpoint on `bind`, answering at most `max_peers` peers at once.
pub async fn open_server<S: Station>(
    bind: SocketAddr,
    max_peers: usize,
    signing: Option<LinkSigning>,
    shared: &Shared<S>,
) -> Result<OpenEndpoint, EndpointError> {
    if max_peers == 0 {
        return Err(EndpointError::NoPeers { bind });
    }
    serve(bind, max_peers, None, signing, shared).await
}

/// A server on `bind` for up to `max_peers` peers that talk first, and `fixed`, a peer it
/// sends to from the start and never forgets.
async fn serve<S: Station>(
    bind: SocketAddr,
    max_peers: usize,
    fixed: Option<SocketAddr>,
    signing: Option<LinkSigning>,
    shared: &Shared<S>,
) -> Result<OpenEndpoint, EndpointError> {
    let endpoint = shared.endpoint;
    let socket = bind_socket(bind, "UDP server").await?;
    let local = socket.local_addr().ok();
    let name = match fixed {
        Some(address) => format!("udp client {bind} -> {address}"),
        None => format!("udp server {bind}"),
    };
    let fixed = fixed.map(|address| {
        let tx = Tx::Udp { socket: Arc::clone(&socket), peer: address };
        (address, shared.add_link(name.clone(), tx, signing.clone()), FrameParser::new())
    });
    let peer_stats = Arc::new(Mutex::new(PeerStats::default()));
    let published = Arc::clone(&peer_stats);
    let shared = shared.clone();
    let server = name.clone();
    tokio::spawn(async move {
        let mut fixed = fixed;
        let mut peers = PeerTable::new(max_peers);
        let mut buf = vec![0u8; DATAGRAM];
        let mut expiry = tokio::time::interval(PEER_TIMEOUT / 3);
        let publish =
            |peers: &PeerTable| *published.lock().unwrap_or_else(|e| e.into_inner()) = peers.stats();
        loop {
            let received = tokio::select! {
                _ = shared.shutdown.cancelled() => break,
                _ = expiry.tick() => {
                    for id in peers.expire(Instant::now(), PEER_TIMEOUT) {
                        shared.hub().remove_link(id);
                    }
                    publish(&peers);
                    continue;
                }
                r = socket.recv_from(&mut buf) => r,
            };
            let Ok((n, peer)) = received else { continue };
            if let Some((address, id, parser)) = &mut fixed
                && *address == peer
            {
                feed(&shared, *id, parser, &buf[..n]);
                continue;
            }
            let now = Instant::now();
            if let Some((id, parser)) = peers.heard(peer, now) {
                feed(&shared, id, parser, &buf[..n]);
                continue;
            }
            let mut parser = FrameParser::new();
            let mut frames = Vec::new();
            parser.push(&buf[..n], &mut frames);
            // Checked here, once: the hub takes these verdicts rather than check again (a second
            // check of a signed frame would find it a replay). An unsigned RADIO_STATUS makes no
            // peer: anyone can send one.
            let verdicts: Option<Vec<Verdict>> =
                signing.as_ref().map(|s| frames.iter().map(|f| s.check(f)).collect());
            let acceptable = match &verdicts {
                Some(v) => v.contains(&Verdict::Signed),
                None => !frames.is_empty(),
            };
            if !acceptable {
                peers.unverified();
                publish(&peers);
                continue;
            }
            match peers.admit(now) {
                Admission::Refuse => {
                    tracing::debug!(server = %server, %peer, "UDP peer refused: the peer table is full");
                }
                Admission::Admit { evict } => {
                    let mut hub = shared.hub();
                    if let Some(old) = evict {
                        hub.remove_link(old);
                    }
                    let tx = Tx::Udp { socket: Arc::clone(&socket), peer };
                    let id = hub.add_endpoint_link(
                        shared.endpoint,
                        format!("udp peer {peer}"),
                        tx,
                        signing.clone(),
                    );
                    drop(hub);
                    peers.insert(peer, id, parser, now);
                    match &verdicts {
                        Some(v) => shared.handle_checked_frames(id, &frames, v),
                        None => shared.handle_frames(id, &frames),
                    }
                }
            }
            publish(&peers);
        }
        tracing::info!(server = %server, stats = ?peers.stats(), "UDP server peer counters");
    });
    Ok(OpenEndpoint { name, endpoint, local_addr: local, peer_stats: Some(peer_stats) })
}

async fn bind_socket(addr: SocketAddr, what: &'static str) -> Result<Arc<UdpSocket>, EndpointError> {
    UdpSocket::bind(addr).await.map(Arc::new).map_err(|source| EndpointError::Bind { what, addr, source })
}

fn feed<S: Station>(shared: &Shared<S>, id: LinkId, parser: &mut FrameParser, datagram: &[u8]) {
    let mut frames = Vec::new();
    parser.push(datagram, &mut frames);
    shared.handle_frames(id, &frames);
}
