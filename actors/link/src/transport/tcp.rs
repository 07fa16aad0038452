//! TCP server endpoint: every accepted connection is its own link.

use std::net::SocketAddr;

use tokio::net::TcpListener;

use super::{EndpointError, LinkSigning, OpenEndpoint, Shared, stream};
use crate::station::Station;

/// Listens on `bind` and serves connections until shutdown.
pub async fn open_server<S: Station>(
    bind: SocketAddr,
    signing: Option<LinkSigning>,
    shared: &Shared<S>,
) -> Result<OpenEndpoint, EndpointError> {
    let endpoint = shared.endpoint;
    let listener = TcpListener::bind(bind).await.map_err(|source| EndpointError::Bind {
        what: "TCP server",
        addr: bind,
        source,
    })?;
    let local = listener.local_addr().map_err(|source| EndpointError::Bind {
        what: "TCP server",
        addr: bind,
        source,
    })?;
    let shared = shared.clone();
    tokio::spawn(async move {
        loop {
            let accepted = tokio::select! {
                _ = shared.shutdown.cancelled() => break,
                a = listener.accept() => a,
            };
            match accepted {
                Ok((socket, peer)) => {
                    let _ = socket.set_nodelay(true);
                    let (r, w) = socket.into_split();
                    stream::spawn(format!("tcp {peer}"), r, w, signing.clone(), shared.clone());
                }
                Err(e) => tracing::warn!(error = %e, "TCP accept failed"),
            }
        }
    });
    Ok(OpenEndpoint {
        name: format!("tcp server {local}"),
        endpoint,
        local_addr: Some(local),
        peer_stats: None,
    })
}
