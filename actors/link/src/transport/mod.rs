//! The I/O shell: sockets and serial ports feeding the [`crate::hub::Hub`]. Every task
//! ends when the actor's shutdown token is cancelled.

mod param_writer;
mod serial;
mod signing;
mod stream;
mod tcp;
mod udp;
mod udp_peers;

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};

use kestrel_proto::Clock;
use tokio_util::sync::CancellationToken;

use crate::config::{EndpointConfig, EndpointKind};
use crate::frame::Frame;
use crate::hub::Hub;
use crate::router::LinkId;
use crate::services::ToGraph;
use crate::services::params::render_param_file;

pub use param_writer::{ParamWriter, WriterStats, write_atomically};
pub use udp_peers::{EVICTABLE_AFTER, PeerStats};

/// Where messages for the graph go (the actor's publishers, or a test's collector).
pub type GraphSink = Arc<dyn Fn(Vec<ToGraph>) + Send + Sync>;

/// Why an endpoint could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum EndpointError {
    #[error("cannot bind {what} on {addr}: {source}")]
    Bind {
        what: &'static str,
        addr: SocketAddr,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot open serial port {device} at {baud} baud: {source}")]
    Serial {
        device: PathBuf,
        baud: u32,
        #[source]
        source: tokio_serial::Error,
    },
    #[error("UDP server on {bind}: max_peers must be at least 1")]
    NoPeers { bind: SocketAddr },
    #[error("signing key {path}: {reason}")]
    SigningKey { path: PathBuf, reason: String },
}

/// What every endpoint task shares.
#[derive(Clone)]
pub struct Shared {
    pub hub: Arc<Mutex<Hub>>,
    pub clock: Arc<dyn Clock>,
    pub shutdown: CancellationToken,
    pub graph: GraphSink,
    /// Persists accepted parameter changes off the receive path (`None`: not persisted).
    pub param_writer: Option<Arc<ParamWriter>>,
}

impl Shared {
    /// The hub, even if a task panicked while holding it (its state stays usable).
    pub fn hub(&self) -> MutexGuard<'_, Hub> {
        self.hub.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Hands frames from link `id` to the hub, then publishes what it produced and queues
    /// changed parameters for the writer thread (never waiting for the disk).
    pub fn handle_frames(&self, id: LinkId, frames: &[Frame]) {
        if frames.is_empty() {
            return;
        }
        let now = self.clock.now();
        let (out, params) = {
            let mut hub = self.hub();
            let out: Vec<ToGraph> = frames.iter().flat_map(|f| hub.on_frame(id, f, now)).collect();
            let vehicle = hub.vehicle();
            let params = (vehicle.take_params_changed() && self.param_writer.is_some())
                .then(|| render_param_file(vehicle.params()));
            (out, params)
        };
        if let (Some(text), Some(writer)) = (params, &self.param_writer) {
            writer.submit(text);
        }
        if !out.is_empty() {
            (self.graph)(out);
        }
    }
}

/// An endpoint that is open, with the address it listens or sends from (serial: `None`).
#[derive(Clone, Debug)]
pub struct OpenEndpoint {
    pub name: String,
    pub local_addr: Option<SocketAddr>,
    /// A UDP server's peer counters (admitted, refused, evicted), updated as they change.
    pub peer_stats: Option<Arc<Mutex<PeerStats>>>,
}

/// Opens every endpoint and spawns its tasks; `config_dir` resolves relative key paths.
pub async fn open_all(
    endpoints: &[EndpointConfig],
    config_dir: &Path,
    shared: &Shared,
) -> Result<Vec<OpenEndpoint>, EndpointError> {
    let mut open = Vec::new();
    let mut failed = None;
    for e in endpoints {
        match open_one(e, u8::try_from(open.len()).unwrap_or(0), config_dir, shared).await {
            Ok(opened) => open.push(opened),
            // One endpoint that cannot open (a radio unplugged, a port in use) must not take
            // the others down: the vehicle stays reachable on what did open.
            Err(error) => {
                tracing::error!(endpoint = ?e.kind, %error, "MAVLink endpoint not opened; the others stay up");
                failed = Some(error);
            }
        }
    }
    match failed {
        Some(error) if open.is_empty() => Err(error),
        _ => Ok(open),
    }
}

async fn open_one(
    e: &EndpointConfig,
    link_id: u8,
    config_dir: &Path,
    shared: &Shared,
) -> Result<OpenEndpoint, EndpointError> {
    let signing = match &e.signing_key_file {
        Some(p) => Some(signing::load(&config_dir.join(p), link_id)?),
        None => None,
    };
    match &e.kind {
        EndpointKind::UdpOut { address, bind, .. } => {
            udp::open_client(*address, *bind, signing, shared).await
        }
        EndpointKind::UdpIn { bind, max_peers } => udp::open_server(*bind, *max_peers, signing, shared).await,
        EndpointKind::TcpIn { bind } => tcp::open_server(*bind, signing, shared).await,
        EndpointKind::Serial { device, baud, flow_control } => {
            serial::open(device, *baud, *flow_control, signing, shared)
        }
    }
}
