//! A MAVLink peer on a loopback UDP socket, written with the `mavlink` crate (not with this
//! crate's framing) so that it checks the link against an independent implementation.

use std::net::{Ipv4Addr, SocketAddr};
use std::time::Duration;

use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::{MavHeader, MavlinkReader, MavlinkVersion, SigningData};
use tokio::net::UdpSocket;

/// A MAVLink peer on a loopback UDP socket.
pub struct Peer {
    pub socket: UdpSocket,
    pub system_id: u32,
    pub version: MavlinkVersion,
    pub signing: Option<SigningData>,
    seq: u8,
}

impl Peer {
    /// A peer bound to an ephemeral loopback port.
    pub async fn bind(system_id: u32) -> Peer {
        let socket = UdpSocket::bind((Ipv4Addr::LOCALHOST, 0)).await.expect("bind loopback");
        Peer { socket, system_id, version: MavlinkVersion::V2, signing: None, seq: 0 }
    }

    pub fn addr(&self) -> SocketAddr {
        self.socket.local_addr().expect("bound")
    }

    /// Sends `msg` to `to`.
    pub async fn send(&mut self, to: SocketAddr, msg: &MavMessage) {
        let header = MavHeader { system_id: self.system_id, component_id: 190, sequence: self.seq };
        self.seq = self.seq.wrapping_add(1);
        let mut buf = Vec::new();
        mavlink::write_versioned_msg_signed(&mut buf, self.version, header, msg, self.signing.as_ref())
            .expect("serialise");
        self.socket.send_to(&buf, to).await.expect("send");
    }

    /// Receives until `pick` returns `Some` or `timeout` passes; returns the pick and the
    /// address it came from.
    pub async fn recv_until<T>(
        &self,
        timeout: Duration,
        mut pick: impl FnMut(&MavHeader, &MavMessage) -> Option<T>,
    ) -> Option<(T, SocketAddr)> {
        let deadline = tokio::time::Instant::now() + timeout;
        let mut buf = vec![0u8; 65_536];
        loop {
            let r = tokio::time::timeout_at(deadline, self.socket.recv_from(&mut buf)).await.ok()?;
            let Ok((n, from)) = r else { continue };
            let mut reader = MavlinkReader::new(&buf[..n]);
            while let Ok((h, m)) = reader.read_any_message::<MavMessage>() {
                if let Some(t) = pick(&h, &m) {
                    return Some((t, from));
                }
            }
        }
    }
}
