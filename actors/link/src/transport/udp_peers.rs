//! Who the UDP server answers. A datagram from an unknown address is worth nothing until it
//! holds a MAVLink frame with a valid checksum (and signature, when the endpoint signs): only
//! then does the address become a peer that gets telemetry. Otherwise a spoofed or stray packet
//! would make the vehicle stream tens of kB/s at any address, and a port scan would fill the
//! table. The table is capped; a newcomer to a full table takes the place of the peer that has
//! been silent longest, but only if that peer has been silent for [`EVICTABLE_AFTER`], so a
//! live ground station (heartbeat at 1 Hz) is never pushed out by a flood of new addresses.

use std::collections::HashMap;
use std::net::SocketAddr;
use std::time::{Duration, Instant};

use crate::frame::FrameParser;
use crate::router::LinkId;

/// Silence after which a peer may give its place to a newcomer when the table is full.
pub const EVICTABLE_AFTER: Duration = Duration::from_secs(3);

/// Counters of one UDP server.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PeerStats {
    /// Addresses that became peers.
    pub admitted: u64,
    /// Datagrams from unknown addresses without one valid frame (dropped, no peer made).
    pub unverified_datagrams: u64,
    /// Valid newcomers refused because the table was full of live peers.
    pub refused_full: u64,
    /// Silent peers pushed out by a newcomer.
    pub evicted: u64,
    /// Peers forgotten after the server's silence timeout.
    pub expired: u64,
}

struct Peer {
    link: LinkId,
    parser: FrameParser,
    heard: Instant,
}

/// What to do with a verified newcomer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Admission {
    /// Register it; first remove this link (a silent peer whose place it takes), if any.
    Admit { evict: Option<LinkId> },
    /// The table is full of live peers: drop the datagram.
    Refuse,
}

/// The UDP server's peers, each with its own frame parser and last-heard time.
pub struct PeerTable {
    peers: HashMap<SocketAddr, Peer>,
    max_peers: usize,
    stats: PeerStats,
}

impl PeerTable {
    /// An empty table holding at most `max_peers` peers.
    pub fn new(max_peers: usize) -> PeerTable {
        PeerTable { peers: HashMap::new(), max_peers, stats: PeerStats::default() }
    }

    /// Counters so far.
    pub fn stats(&self) -> PeerStats {
        self.stats
    }

    /// A known peer's link and parser, marking it heard at `now`.
    pub fn heard(&mut self, addr: SocketAddr, now: Instant) -> Option<(LinkId, &mut FrameParser)> {
        let peer = self.peers.get_mut(&addr)?;
        peer.heard = now;
        Some((peer.link, &mut peer.parser))
    }

    /// Notes a datagram from an unknown address that held no acceptable frame.
    pub fn unverified(&mut self) {
        self.stats.unverified_datagrams += 1;
    }

    /// Decides on a newcomer whose datagram held a valid frame. On `Admit`, the evicted peer
    /// (if any) is already gone from the table; call [`PeerTable::insert`] with its new link.
    pub fn admit(&mut self, now: Instant) -> Admission {
        if self.peers.len() < self.max_peers {
            return Admission::Admit { evict: None };
        }
        let quietest = self
            .peers
            .iter()
            .filter(|(_, p)| now.saturating_duration_since(p.heard) >= EVICTABLE_AFTER)
            .min_by_key(|(_, p)| p.heard)
            .map(|(addr, _)| *addr);
        match quietest.and_then(|addr| self.peers.remove(&addr)) {
            Some(old) => {
                self.stats.evicted += 1;
                Admission::Admit { evict: Some(old.link) }
            }
            None => {
                self.stats.refused_full += 1;
                Admission::Refuse
            }
        }
    }

    /// Registers an admitted peer; `parser` is the one that found its first frames (it may hold
    /// the start of the next).
    pub fn insert(&mut self, addr: SocketAddr, link: LinkId, parser: FrameParser, now: Instant) {
        self.stats.admitted += 1;
        self.peers.insert(addr, Peer { link, parser, heard: now });
    }

    /// Removes peers silent for `timeout` and returns their links.
    pub fn expire(&mut self, now: Instant, timeout: Duration) -> Vec<LinkId> {
        let mut gone = Vec::new();
        self.peers.retain(|_, p| {
            let alive = now.saturating_duration_since(p.heard) < timeout;
            if !alive {
                gone.push(p.link);
            }
            alive
        });
        self.stats.expired += gone.len() as u64;
        gone
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn addr(port: u16) -> SocketAddr {
        SocketAddr::from(([127, 0, 0, 1], port))
    }

    fn fill(table: &mut PeerTable, t0: Instant, ports: std::ops::Range<u16>) {
        for (i, port) in ports.enumerate() {
            let now = t0 + Duration::from_millis(i as u64);
            assert_eq!(table.admit(now), Admission::Admit { evict: None });
            table.insert(addr(port), LinkId::from(port), FrameParser::new(), now);
        }
    }

    #[test]
    fn a_full_table_of_live_peers_refuses_newcomers_and_counts_them() {
        let t0 = Instant::now();
        let mut table = PeerTable::new(3);
        fill(&mut table, t0, 1..4);
        let soon = t0 + Duration::from_secs(1);
        assert_eq!(table.admit(soon), Admission::Refuse);
        assert_eq!(table.admit(soon), Admission::Refuse);
        assert!((1..4).all(|port| table.heard(addr(port), soon).is_some()));
        assert_eq!(table.stats(), PeerStats { admitted: 3, refused_full: 2, ..PeerStats::default() });
    }

    #[test]
    fn a_newcomer_takes_the_place_of_the_peer_silent_longest() {
        let t0 = Instant::now();
        let mut table = PeerTable::new(3);
        fill(&mut table, t0, 1..4);
        // Peer 1 keeps talking; 2 fell silent before 3.
        let later = t0 + Duration::from_secs(10);
        assert!(table.heard(addr(1), later).is_some());
        assert_eq!(table.admit(later), Admission::Admit { evict: Some(2) });
        table.insert(addr(9), 9, FrameParser::new(), later);
        assert!(table.heard(addr(2), later).is_none());
        assert_eq!(table.heard(addr(9), later).map(|(l, _)| l), Some(9));
        assert_eq!(table.admit(later), Admission::Admit { evict: Some(3) });
        assert_eq!(table.stats().evicted, 2);
    }

    #[test]
    fn silent_peers_expire() {
        let t0 = Instant::now();
        let mut table = PeerTable::new(8);
        fill(&mut table, t0, 1..3);
        assert!(table.heard(addr(2), t0 + Duration::from_secs(20)).is_some());
        assert_eq!(table.expire(t0 + Duration::from_secs(31), Duration::from_secs(30)), vec![1]);
        assert!(table.heard(addr(1), t0 + Duration::from_secs(31)).is_none());
        assert_eq!(table.stats().expired, 1);
    }
}
