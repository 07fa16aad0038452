//! Serial endpoint, e.g. a 433 MHz SiK radio (57600 baud 8N1 by default, optional RTS/CTS).
//! A port that reads end-of-file or fails (a USB radio unplugged) is reopened with back-off
//! until shutdown, as the GPS driver does, so the link comes back when the radio does (held by
//! tests/serial.rs `a_serial_link_that_disappears_carries_traffic_again_when_it_returns`).

use std::path::{Path, PathBuf};
use std::time::Duration;

use tokio_serial::{FlowControl, SerialPortBuilderExt, SerialStream};

use super::{EndpointError, LinkSigning, OpenEndpoint, Shared, stream};
use crate::station::Station;

/// First wait before reopening a port that closed; doubled after each failed attempt up to
/// [`REOPEN_MAX`], so a radio that returns is serving again within about a second.
const REOPEN_FIRST: Duration = Duration::from_millis(100);
/// Longest wait between reopening attempts.
const REOPEN_MAX: Duration = Duration::from_secs(1);

/// Opens `device` and runs it as one link, reopened after end-of-file or an error.
pub fn open<S: Station>(
    device: &Path,
    baud: u32,
    flow_control: bool,
    signing: Option<LinkSigning>,
    shared: &Shared<S>,
) -> Result<OpenEndpoint, EndpointError> {
    let port = open_port(device, baud, flow_control)?;
    let endpoint = shared.endpoint;
    let name = format!("serial {}", device.display());
    let device = device.to_owned();
    let shared = shared.clone();
    let link = name.clone();
    tokio::spawn(async move {
        let mut port = Some(port);
        let mut wait = REOPEN_FIRST;
        loop {
            if let Some(p) = port.take() {
                let (r, w) = tokio::io::split(p);
                stream::run(link.clone(), r, w, signing.clone(), shared.clone()).await;
                wait = REOPEN_FIRST;
            }
            tokio::select! {
                _ = shared.shutdown.cancelled() => break,
                _ = tokio::time::sleep(wait) => {}
            }
            match open_port(&device, baud, flow_control) {
                Ok(p) => {
                    tracing::info!(link = %link, "serial port reopened");
                    port = Some(p);
                }
                Err(error) => {
                    tracing::debug!(link = %link, %error, "serial port not back yet");
                    wait = next_wait(wait);
                }
            }
        }
    });
    Ok(OpenEndpoint { name, endpoint, local_addr: None, peer_stats: None })
}

fn open_port(device: &Path, baud: u32, flow_control: bool) -> Result<SerialStream, EndpointError> {
    let path = device.to_string_lossy().into_owned();
    tokio_serial::new(&path, baud)
        .flow_control(if flow_control { FlowControl::Hardware } else { FlowControl::None })
        .open_native_async()
        .map_err(|source| EndpointError::Serial { device: PathBuf::from(device), baud, source })
}

/// The back-off after a failed reopening attempt.
fn next_wait(wait: Duration) -> Duration {
    (wait * 2).min(REOPEN_MAX)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_back_off_doubles_from_a_tenth_of_a_second_and_stops_at_one() {
        let mut w = REOPEN_FIRST;
        let mut seen = vec![w];
        for _ in 0..6 {
            w = next_wait(w);
            seen.push(w);
        }
        let ms: Vec<u128> = seen.iter().map(Duration::as_millis).collect();
        assert_eq!(ms, [100, 200, 400, 800, 1000, 1000, 1000]);
    }
}
