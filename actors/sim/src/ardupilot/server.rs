//! The UDP shell around [`JsonBackend`]: SITL's servo packets in, its answers back to the
//! address each came from. Blocking on purpose: in lockstep nothing happens between packets,
//! and physics time stops while none arrive (SITL resends after a second, so a lost datagram
//! costs a second, never a frame).

use std::io;
use std::net::{SocketAddr, UdpSocket};
use std::time::Duration;

use super::backend::{JsonBackend, Summary};

/// SITL's physics port for instance 0; instance N uses this + 10·N (`-I N`).
pub const BASE_PORT: u16 = 9002;
/// How long one wait for a packet lasts before `stop` is asked again.
const POLL: Duration = Duration::from_millis(100);

/// A bound physics port and the backend answering on it.
pub struct JsonServer {
    socket: UdpSocket,
    backend: JsonBackend,
}

impl JsonServer {
    /// Binds 127.0.0.1 on SITL instance `instance`'s physics port.
    pub fn bind(backend: JsonBackend, instance: u16) -> io::Result<JsonServer> {
        let port = BASE_PORT.checked_add(instance.saturating_mul(10)).ok_or_else(|| {
            io::Error::new(io::ErrorKind::InvalidInput, format!("instance {instance}: no port"))
        })?;
        JsonServer::bind_to(backend, SocketAddr::from(([127, 0, 0, 1], port)))
    }

    /// Binds `addr` (port 0: any free port, for tests).
    pub fn bind_to(backend: JsonBackend, addr: SocketAddr) -> io::Result<JsonServer> {
        let socket = UdpSocket::bind(addr)?;
        socket.set_read_timeout(Some(POLL))?;
        Ok(JsonServer { socket, backend })
    }

    /// The address it answers on.
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.socket.local_addr()
    }

    /// Answers packets until `stop` (asked every [`POLL`] without a packet and every 1200
    /// frames) says so; returns what the run did. A datagram that is no servo packet is logged
    /// once a second at most, counted and left unanswered.
    pub fn serve(&mut self, mut stop: impl FnMut(&Summary) -> bool) -> io::Result<Summary> {
        let mut buf = [0_u8; 256];
        let mut since_check = 0_u32;
        loop {
            match self.socket.recv_from(&mut buf) {
                Ok((len, from)) => match self.backend.answer(&buf[..len]) {
                    Ok(reply) => {
                        // A signal (the one that stops the run) may interrupt the send: send again.
                        while let Err(e) = self.socket.send_to(reply.as_bytes(), from) {
                            if e.kind() != io::ErrorKind::Interrupted {
                                return Err(e);
                            }
                        }
                        since_check += 1;
                        if since_check >= 1200 {
                            since_check = 0;
                            if stop(&self.backend.summary()) {
                                break;
                            }
                        }
                    }
                    Err(e) => {
                        let refused = self.backend.summary().refused_packets;
                        if refused.is_power_of_two() || refused == 0 {
                            tracing::warn!("ArduPilot physics port: refused a datagram from {from}: {e}");
                        }
                        self.backend.count_refused_packet();
                    }
                },
                // No packet within POLL, or a signal arrived (SIGTERM ends a run): ask `stop`.
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut | io::ErrorKind::Interrupted
                    ) =>
                {
                    if stop(&self.backend.summary()) {
                        break;
                    }
                }
                Err(e) => return Err(e),
            }
        }
        Ok(self.backend.summary())
    }

    /// The backend, for inspection.
    pub fn backend(&self) -> &JsonBackend {
        &self.backend
    }
}
