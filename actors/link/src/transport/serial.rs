//! Serial endpoint, e.g. a 433 MHz SiK radio (57600 baud 8N1 by default, optional RTS/CTS).

use std::path::Path;
use std::sync::Arc;

use mavlink::SigningData;
use tokio_serial::{FlowControl, SerialPortBuilderExt};

use super::{EndpointError, OpenEndpoint, Shared, stream};

/// Opens `device` and runs it as one link.
pub fn open(
    device: &Path,
    baud: u32,
    flow_control: bool,
    signing: Option<Arc<SigningData>>,
    shared: &Shared,
) -> Result<OpenEndpoint, EndpointError> {
    let path = device.to_string_lossy().into_owned();
    let port = tokio_serial::new(&path, baud)
        .flow_control(if flow_control { FlowControl::Hardware } else { FlowControl::None })
        .open_native_async()
        .map_err(|source| EndpointError::Serial { device: device.to_owned(), baud, source })?;
    let (r, w) = tokio::io::split(port);
    let name = format!("serial {path}");
    stream::spawn(name.clone(), r, w, signing, shared.clone());
    Ok(OpenEndpoint { name, local_addr: None, peer_stats: None })
}
