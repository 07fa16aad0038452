//! The I/O shell: sockets and serial ports feeding the [`crate::hub::Hub`]. Every task
//! ends when the actor's shutdown token is cancelled.

mod param_persistence;
mod param_writer;
mod serial;
pub mod setup_signing;
pub mod signing;
pub mod signing_key;
pub mod signing_store;
mod stream;
mod tcp;
mod udp;
mod udp_peers;

use std::collections::HashMap;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};

use kestrel_proto::Clock;
use tokio_util::sync::CancellationToken;

use crate::config::{EndpointConfig, EndpointKind};
use crate::frame::Frame;
use crate::hub::Hub;
use crate::router::LinkId;
use crate::station::{EndpointIndex, Station};
use crate::vehicle::Vehicle;

pub use param_persistence::param_writer_for;
pub use param_writer::{ParamWriter, Report, WriterStats, file_writer, write_atomically};
pub use signing::{LinkSigning, SigningStats, Streams, Verdict};
pub use signing_key::{KeyError, SigningKey};
pub use udp_peers::{EVICTABLE_AFTER, PeerStats};

/// Where messages for the graph go (the actor's publishers, or a test's collector).
pub type GraphSink<G = crate::services::ToGraph> = Arc<dyn Fn(Vec<G>) + Send + Sync>;

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
    #[error(transparent)]
    SigningKey(#[from] KeyError),
}

/// What every endpoint task shares.
pub struct Shared<S: Station = Vehicle> {
    pub hub: Arc<Mutex<Hub<S>>>,
    pub clock: Arc<dyn Clock>,
    pub shutdown: CancellationToken,
    pub graph: GraphSink<S::Graph>,
    /// Persists accepted parameter changes off the receive path (`None`: not persisted).
    pub param_writer: Option<Arc<ParamWriter>>,
    /// The endpoint whose tasks hold this copy (set by `open_all`): links it opens carry it.
    pub endpoint: EndpointIndex,
}

impl<S: Station> Clone for Shared<S> {
    fn clone(&self) -> Self {
        Shared {
            hub: Arc::clone(&self.hub),
            clock: Arc::clone(&self.clock),
            shutdown: self.shutdown.clone(),
            graph: Arc::clone(&self.graph),
            param_writer: self.param_writer.clone(),
            endpoint: self.endpoint,
        }
    }
}

impl<S: Station> Shared<S> {
    /// The hub, even if a task panicked while holding it (its state stays usable).
    pub fn hub(&self) -> MutexGuard<'_, Hub<S>> {
        self.hub.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Adds a link of this endpoint to the hub.
    pub fn add_link(&self, name: String, tx: crate::hub::Tx, signing: Option<LinkSigning>) -> LinkId {
        self.hub().add_endpoint_link(self.endpoint, name, tx, signing)
    }

    /// Hands frames from link `id` to the hub, then publishes what it produced and queues
    /// changed parameters for the writer thread (never waiting for the disk).
    pub fn handle_frames(&self, id: LinkId, frames: &[Frame]) {
        self.handle(id, frames, None);
    }

    /// [`Shared::handle_frames`] for frames whose signatures the caller already checked
    /// (`verdicts[i]` is `frames[i]`'s): each frame is checked once, as a second check of the
    /// same frame would find it a replay.
    pub fn handle_checked_frames(&self, id: LinkId, frames: &[Frame], verdicts: &[Verdict]) {
        self.handle(id, frames, Some(verdicts));
    }

    fn handle(&self, id: LinkId, frames: &[Frame], verdicts: Option<&[Verdict]>) {
        if frames.is_empty() {
            return;
        }
        let now = self.clock.now();
        let (out, params) = {
            let mut hub = self.hub();
            let out: Vec<S::Graph> = frames
                .iter()
                .enumerate()
                .flat_map(|(i, f)| hub.on_checked_frame(id, f, verdicts.and_then(|v| v.get(i)).copied(), now))
                .collect();
            let params = self.param_writer.as_ref().and_then(|_| hub.station().take_param_write());
            (out, params)
        };
        if let (Some(write), Some(writer)) = (params, &self.param_writer) {
            writer.submit_tagged(write.batch, write.text);
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
    /// Its index in the endpoint list it was opened from.
    pub endpoint: EndpointIndex,
    pub local_addr: Option<SocketAddr>,
    /// A UDP server's peer counters (admitted, refused, evicted), updated as they change.
    pub peer_stats: Option<Arc<Mutex<PeerStats>>>,
}

/// Opens every endpoint and spawns its tasks; `config_dir` resolves relative key paths and
/// holds the stored signing timestamp. Every signing endpoint shares one [`Streams`] (one
/// replay table, one timestamp), and endpoints naming the same key file share its key.
pub async fn open_all<S: Station>(
    endpoints: &[EndpointConfig],
    config_dir: &Path,
    shared: &Shared<S>,
) -> Result<Vec<OpenEndpoint>, EndpointError> {
    let streams = endpoints.iter().any(|e| e.signing_key_file.is_some()).then(|| {
        let system_id = shared.hub().station().signing_store_id();
        start_signing_clock(config_dir, system_id, &shared.shutdown)
    });
    let mut keys: HashMap<PathBuf, Arc<SigningKey>> = HashMap::new();
    let mut open = Vec::new();
    let mut failed = None;
    for (index, e) in endpoints.iter().enumerate() {
        let link_id = u8::try_from(open.len()).unwrap_or(0);
        let shared = Shared { endpoint: index, ..shared.clone() };
        let signing = match (&e.signing_key_file, &streams) {
            (Some(file), Some(streams)) => {
                let path = config_dir.join(file);
                let key = match keys.get(&path) {
                    Some(key) => Ok(Arc::clone(key)),
                    None => SigningKey::load(&path).map(Arc::new),
                };
                match key {
                    Ok(key) => {
                        keys.insert(path, Arc::clone(&key));
                        let secure = matches!(e.kind, EndpointKind::Serial { .. });
                        Ok(Some(LinkSigning { streams: Arc::clone(streams), key, link_id, secure }))
                    }
                    Err(error) => Err(EndpointError::from(error)),
                }
            }
            _ => Ok(None),
        };
        match signing {
            Ok(signing) => match open_one(e, signing, &shared).await {
                Ok(opened) => open.push(opened),
                Err(error) => failed = Some(not_opened(e, error)),
            },
            Err(error) => failed = Some(not_opened(e, error)),
        }
    }
    match failed {
        Some(error) if open.is_empty() => Err(error),
        _ => Ok(open),
    }
}

/// One endpoint that cannot open (a radio unplugged, a port in use, a key file others may read)
/// must not take the others down: the vehicle stays reachable on what did open.
fn not_opened(e: &EndpointConfig, error: EndpointError) -> EndpointError {
    tracing::error!(endpoint = ?e.kind, %error, "MAVLink endpoint not opened; the others stay up");
    error
}

/// The shared signing state, restored from the stored timestamp, with its saver task.
fn start_signing_clock(config_dir: &Path, system_id: u8, shutdown: &CancellationToken) -> Arc<Streams> {
    let file = signing_store::TimestampFile::in_dir(config_dir, system_id);
    let stored = file.load().unwrap_or_else(|error| {
        // Without it, replay protection across this restart rests on the system clock alone.
        tracing::error!(%error, "stored signing timestamp unreadable; starting from the system clock");
        None
    });
    let streams = Arc::new(Streams::new(stored, signing::wall_timestamp()));
    tracing::info!(path = %file.path().display(), ?stored, timestamp = streams.timestamp(), "MAVLink signing clock");
    signing_store::spawn_saver(
        file,
        Arc::clone(&streams),
        stored,
        signing_store::SAVE_PERIOD,
        shutdown.clone(),
    );
    streams
}

async fn open_one<S: Station>(
    e: &EndpointConfig,
    signing: Option<LinkSigning>,
    shared: &Shared<S>,
) -> Result<OpenEndpoint, EndpointError> {
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
