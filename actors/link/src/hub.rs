//! The link's switchboard: every endpoint's frames come here (under one lock, never across an
//! await), are checked for signatures, routed to the other links, and — when addressed to us —
//! handed to the [`Vehicle`]. What the vehicle answers is encoded per link (own sequence number,
//! own signing key) and sent without waiting: a link that cannot take a frame drops it and
//! counts the drop rather than stall the others.

use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::sync::Arc;

use kestrel_proto::Time;
use mavlink::dialects::ardupilotmega::{MavMessage, SETUP_SIGNING_DATA};
use mavlink::{MavHeader, Message, MessageData};
use tokio::net::UdpSocket;
use tokio::sync::mpsc;

use crate::frame::{Frame, encode};
use crate::router::{LinkId, Router};
use crate::services::{Outputs, Sender, ToGraph};
use crate::station::{EndpointIndex, Station, StationOut};
use crate::transport::{LinkSigning, SigningStats, Verdict, setup_signing};
use crate::vehicle::Vehicle;

/// How a link sends.
#[derive(Debug)]
pub enum Tx {
    /// A UDP peer, through a shared socket (non-blocking `try_send_to`).
    Udp { socket: Arc<UdpSocket>, peer: SocketAddr },
    /// A byte stream (TCP, serial) with its own writer task.
    Stream(mpsc::Sender<Vec<u8>>),
}

impl Tx {
    fn send(&self, bytes: Vec<u8>) -> bool {
        match self {
            Tx::Udp { socket, peer } => socket.try_send_to(&bytes, *peer).is_ok(),
            Tx::Stream(tx) => tx.try_send(bytes).is_ok(),
        }
    }
}

/// Counters of one link.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkStats {
    pub frames_in: u64,
    pub frames_out: u64,
    /// What the signature check made of inbound frames (all zero when the link does not sign).
    pub signing: SigningStats,
    /// Frames the link could not take (full queue, socket not ready).
    pub send_dropped: u64,
    /// Telemetry skipped because the radio reported a filling buffer.
    pub thinned: u64,
}

struct LinkState {
    name: String,
    /// The config endpoint that opened it.
    endpoint: EndpointIndex,
    tx: Tx,
    signing: Option<LinkSigning>,
    sequence: u8,
    /// Free transmit buffer (%) from the last RADIO_STATUS heard on this link.
    txbuf: Option<u8>,
    thin_counter: u32,
    stats: LinkStats,
}

impl LinkState {
    /// Telemetry divisor from the radio's free buffer, as ArduPilot throttles streams:
    /// below 20 % free keep 1 in 4, below 50 % 1 in 2.
    fn keep_telemetry(&mut self) -> bool {
        let every = match self.txbuf {
            Some(b) if b < 20 => 4,
            Some(b) if b < 50 => 2,
            _ => 1,
        };
        self.thin_counter = self.thin_counter.wrapping_add(1);
        self.thin_counter.is_multiple_of(every)
    }
}

/// Counters of the whole hub.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HubStats {
    /// Frames with a valid checksum whose payload would not decode (bad enum value, ...).
    pub undecodable: u64,
    /// Addressed messages whose target was never heard.
    pub unroutable: u64,
    /// Messages addressed to us that no service uses.
    pub unhandled: u64,
    /// Frames that claimed our own system id: dropped unrouted and unread (see `Hub::on_frame`).
    pub own_id_refused: u64,
}

/// Every link, the router and the station (the vehicle, or a companion computer).
pub struct Hub<S: Station = Vehicle> {
    station: S,
    router: Router,
    links: BTreeMap<LinkId, LinkState>,
    next_id: LinkId,
    undecodable: u64,
    own_id_refused: u64,
}

impl Hub<Vehicle> {
    /// The vehicle (for the actor's inputs and for tests).
    pub fn vehicle(&mut self) -> &mut Vehicle {
        &mut self.station
    }

    /// Sends the services' messages and returns what goes to the graph.
    pub fn dispatch(&mut self, out: Outputs) -> Vec<ToGraph> {
        self.send_messages(&out.mav);
        out.graph
    }
}

impl<S: Station> Hub<S> {
    /// A hub with no links yet.
    pub fn new(station: S) -> Hub<S> {
        Hub {
            station,
            router: Router::new(),
            links: BTreeMap::new(),
            next_id: 1,
            undecodable: 0,
            own_id_refused: 0,
        }
    }

    /// The station (for the actor's inputs and for tests).
    pub fn station(&mut self) -> &mut S {
        &mut self.station
    }

    /// Adds a link of endpoint 0; `signing` on means signed output and only validly signed input.
    pub fn add_link(&mut self, name: String, tx: Tx, signing: Option<LinkSigning>) -> LinkId {
        self.add_endpoint_link(0, name, tx, signing)
    }

    /// Adds a link opened by `endpoint` (its index in the config's endpoint list).
    pub fn add_endpoint_link(
        &mut self,
        endpoint: EndpointIndex,
        name: String,
        tx: Tx,
        signing: Option<LinkSigning>,
    ) -> LinkId {
        let id = self.next_id;
        self.next_id += 1;
        tracing::info!(link = %name, "MAVLink link up");
        self.links.insert(
            id,
            LinkState {
                name,
                endpoint,
                tx,
                signing,
                sequence: 0,
                txbuf: None,
                thin_counter: 0,
                stats: LinkStats::default(),
            },
        );
        self.router.add_link(id);
        id
    }

    /// Removes a closed link.
    pub fn remove_link(&mut self, id: LinkId) {
        if let Some(l) = self.links.remove(&id) {
            tracing::info!(link = %l.name, "MAVLink link down");
        }
        self.router.remove_link(id);
    }

    /// `(name, counters)` of every link.
    pub fn link_stats(&self) -> Vec<(String, LinkStats)> {
        self.links.values().map(|l| (l.name.clone(), l.stats)).collect()
    }

    /// Hub-wide counters.
    pub fn stats(&self) -> HubStats {
        HubStats {
            undecodable: self.undecodable,
            unroutable: self.router.unroutable(),
            unhandled: self.station.unhandled(),
            own_id_refused: self.own_id_refused,
        }
    }

    /// A frame arrived on `link`: check its signature, route, and handle it if it is for us.
    pub fn on_frame(&mut self, link: LinkId, frame: &Frame, now: Time) -> Vec<S::Graph> {
        self.on_checked_frame(link, frame, None, now)
    }

    /// [`Hub::on_frame`] for a frame whose signature the caller already checked (`verdict`);
    /// with `None`, a signing link checks it here.
    pub fn on_checked_frame(
        &mut self,
        link: LinkId,
        frame: &Frame,
        verdict: Option<Verdict>,
        now: Time,
    ) -> Vec<S::Graph> {
        let Some(state) = self.links.get_mut(&link) else { return Vec::new() };
        if let Some(verdict) = verdict.or_else(|| state.signing.as_ref().map(|s| s.check(frame))) {
            state.stats.signing.count(verdict);
            if !verdict.accepted() {
                return Vec::new();
            }
        }
        state.stats.frames_in += 1;
        let endpoint = state.endpoint;
        // Only this process speaks with our system id: a frame that claims it is a loop, a
        // second vehicle configured with our id, or a forgery (an "armed" HEARTBEAT, a position of
        // 1e38 m). Routing it would show the ground station a vehicle that is not there, and
        // learning it would route our own traffic back; mavlink-router and ArduPilot drop such
        // frames too. Counted, and said once in the log.
        if self.station.claims_ours(frame) {
            if self.own_id_refused == 0 {
                tracing::warn!(link = %state.name, "a frame claimed our system id: dropped (counted in own_id_refused)");
            }
            self.own_id_refused += 1;
            return Vec::new();
        }
        self.router.learn(link, frame.system_id);
        let msg = frame.decode();
        if msg.is_err() {
            self.undecodable += 1;
        }
        let target = msg.as_ref().ok().and_then(|m| m.target_system_id());
        let target_component = msg.as_ref().ok().and_then(|m| m.target_component_id());
        let ours = matches!((target, target_component), (Some(s), Some(c)) if self.station.consumes(s, c));
        // SETUP_SIGNING carries a secret key: it goes no further than the link it came on, even
        // broadcast (held by `setup_signing_is_never_forwarded`).
        let dests = match frame.message_id {
            SETUP_SIGNING_DATA::ID => Vec::new(),
            _ if ours => Vec::new(),
            _ => self.router.destinations(Some(link), target),
        };
        for dest in dests {
            self.send_raw(dest, frame.bytes().to_vec());
        }
        if let Ok(MavMessage::RADIO_STATUS(r)) = &msg
            && let Some(state) = self.links.get_mut(&link)
        {
            state.txbuf = Some(r.txbuf);
        }
        if let Ok(m @ MavMessage::SETUP_SIGNING(setup)) = &msg {
            if self.station.is_for_us(m) {
                let signing = self.links.get(&link).and_then(|l| l.signing.as_ref());
                let answer = setup_signing::handle(signing, setup);
                self.send_own(&answer, false);
            }
            return Vec::new();
        }
        let sender = Sender { system_id: frame.system_id, component_id: frame.component_id };
        let out = self.station.receive(endpoint, sender, frame, msg.as_ref().ok(), now);
        self.apply(out)
    }

    /// Sends a station's messages and returns what goes to the graph.
    pub fn apply(&mut self, out: StationOut<S::Graph>) -> Vec<S::Graph> {
        self.send_messages(&out.mav);
        for msg in &out.telemetry {
            self.send_own(msg, true);
        }
        out.graph
    }

    /// Sends `mav` under our identity (never thinned).
    pub fn send_messages(&mut self, mav: &[MavMessage]) {
        for msg in mav {
            self.send_own(msg, false);
        }
    }

    /// Our HEARTBEAT on every link (none while the station does not know who it is).
    pub fn send_heartbeat(&mut self) {
        if let Some(hb) = self.station.heartbeat() {
            self.send_own(&hb, false);
        }
    }

    /// Periodic work: timeouts and due telemetry.
    pub fn on_tick(&mut self, now: Time) -> Vec<S::Graph> {
        let out = self.station.on_tick(now);
        self.apply(out)
    }

    fn send_own(&mut self, msg: &MavMessage, telemetry: bool) {
        let Some((system_id, component_id)) = self.station.identity() else { return };
        let system_id = u32::from(system_id);
        for dest in self.router.destinations(None, msg.target_system_id()) {
            let Some(state) = self.links.get_mut(&dest) else { continue };
            if telemetry && !state.keep_telemetry() {
                state.stats.thinned += 1;
                continue;
            }
            let header = MavHeader { system_id, component_id, sequence: state.sequence };
            state.sequence = state.sequence.wrapping_add(1);
            let bytes = encode(header, msg, state.signing.as_ref());
            if state.tx.send(bytes) {
                state.stats.frames_out += 1;
            } else {
                state.stats.send_dropped += 1;
            }
        }
    }

    fn send_raw(&mut self, dest: LinkId, bytes: Vec<u8>) {
        if let Some(state) = self.links.get_mut(&dest) {
            if state.tx.send(bytes) {
                state.stats.frames_out += 1;
            } else {
                state.stats.send_dropped += 1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use mavlink::dialects::ardupilotmega::{HEARTBEAT_DATA, MavType, PARAM_REQUEST_READ_DATA};
    use proptest::prelude::*;

    use super::*;
    use crate::config::{ParamKind, ParamSpec};
    use crate::frame::{FrameParser, encode_v1};
    use crate::services::params::ParamTable;

    fn hub() -> (Hub, LinkId, mpsc::Receiver<Vec<u8>>) {
        let spec = ParamSpec {
            name: "P".into(),
            value: 1.0,
            min: 0.0,
            max: 2.0,
            kind: ParamKind::Real32,
            unit: String::new(),
        };
        let table = ParamTable::new(vec![spec]).expect("valid");
        let mut hub = Hub::new(Vehicle::new(1, table, Duration::from_secs(5)));
        let (tx, rx) = mpsc::channel(10_000);
        let id = hub.add_link("test".into(), Tx::Stream(tx), None);
        (hub, id, rx)
    }

    fn feed(hub: &mut Hub, link: LinkId, parser: &mut FrameParser, bytes: &[u8]) {
        let mut frames = Vec::new();
        parser.push(bytes, &mut frames);
        for f in &frames {
            hub.on_frame(link, f, Time::ZERO);
        }
    }

    fn read_p() -> Vec<u8> {
        let mut r = PARAM_REQUEST_READ_DATA {
            param_index: 0,
            target_system: 1,
            target_component: 1,
            ..Default::default()
        };
        r.param_id = "P".into();
        encode_v1(
            MavHeader { system_id: 255, component_id: 190, sequence: 0 },
            &MavMessage::PARAM_REQUEST_READ(r),
        )
    }

    #[test]
    fn frames_claiming_our_system_id_are_neither_forwarded_nor_obeyed() {
        let (mut hub, gcs, mut gcs_rx) = hub();
        let (tx, mut other_rx) = mpsc::channel(100);
        let other = hub.add_link("other".into(), Tx::Stream(tx), None);
        let mut parser = FrameParser::new();
        let forged_armed = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            mavtype: MavType::MAV_TYPE_QUADROTOR,
            base_mode: mavlink::dialects::ardupilotmega::MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED,
            ..Default::default()
        });
        let mut forged =
            encode(MavHeader { system_id: 1, component_id: 1, sequence: 0 }, &forged_armed, None);
        let mut read = read_p();
        // The same PARAM_REQUEST_READ, but claiming to come from us (system 1).
        read = {
            let mut frames = Vec::new();
            FrameParser::new().push(&read, &mut frames);
            let msg = frames[0].decode().expect("valid");
            encode(MavHeader { system_id: 1, component_id: 190, sequence: 1 }, &msg, None)
        };
        forged.extend(read);
        feed(&mut hub, other, &mut parser, &forged);
        assert!(gcs_rx.try_recv().is_err(), "a forged frame reached the ground station's link");
        assert!(other_rx.try_recv().is_err(), "a frame claiming our id was answered");
        assert_eq!(hub.stats().own_id_refused, 2);
        // A real ground station is still served and routed.
        feed(&mut hub, gcs, &mut FrameParser::new(), &read_p());
        assert!(gcs_rx.try_recv().is_ok(), "PARAM_VALUE for the ground station");
    }

    #[test]
    fn setup_signing_is_never_forwarded() {
        let (mut hub, gcs, mut gcs_rx) = hub();
        let (tx, mut other_rx) = mpsc::channel(100);
        let other = hub.add_link("other".into(), Tx::Stream(tx), None);
        let mut parser = FrameParser::new();
        // The other link has a peer, so broadcasts would reach it.
        let hb =
            MavMessage::HEARTBEAT(HEARTBEAT_DATA { mavtype: MavType::MAV_TYPE_GCS, ..Default::default() });
        feed(
            &mut hub,
            other,
            &mut parser,
            &encode_v1(MavHeader { system_id: 200, component_id: 1, sequence: 0 }, &hb),
        );
        while gcs_rx.try_recv().is_ok() {}
        let setup = MavMessage::SETUP_SIGNING(mavlink::dialects::ardupilotmega::SETUP_SIGNING_DATA {
            initial_timestamp: 1,
            target_system: 0,
            target_component: 0,
            secret_key: [3; 32],
        });
        let bytes = encode(MavHeader { system_id: 255, component_id: 190, sequence: 0 }, &setup, None);
        feed(&mut hub, gcs, &mut FrameParser::new(), &bytes);
        while let Ok(b) = other_rx.try_recv() {
            let mut frames = Vec::new();
            FrameParser::new().push(&b, &mut frames);
            assert!(frames.iter().all(|f| f.message_id != SETUP_SIGNING_DATA::ID), "the key left its link");
        }
        let answer = gcs_rx.try_recv().expect("a STATUSTEXT");
        let mut frames = Vec::new();
        FrameParser::new().push(&answer, &mut frames);
        assert!(matches!(frames[0].decode(), Ok(MavMessage::STATUSTEXT(_))), "{:?}", frames[0].decode());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]
        /// Random and mutated frames into the whole inbound path: no panic, and a valid request
        /// afterwards is still answered (nothing stalled).
        #[test]
        fn random_and_mutated_frames_never_stall_the_inbound_path(
            noise in proptest::collection::vec(any::<u8>(), 0..2000),
            flips in proptest::collection::vec((any::<usize>(), any::<u8>()), 0..8),
        ) {
            let (mut hub, link, mut rx) = hub();
            let mut parser = FrameParser::new();
            let hb = MavMessage::HEARTBEAT(HEARTBEAT_DATA { mavtype: MavType::MAV_TYPE_GCS, ..Default::default() });
            let mut mutated = encode(MavHeader { system_id: 255, component_id: 190, sequence: 0 }, &hb, None);
            mutated.extend(read_p());
            for (i, x) in &flips {
                let n = mutated.len();
                mutated[i % n] ^= x;
            }
            feed(&mut hub, link, &mut parser, &noise);
            feed(&mut hub, link, &mut parser, &mutated);
            // A fresh stream: a long garbage length byte may legitimately hold the old one.
            let mut parser = FrameParser::new();
            while rx.try_recv().is_ok() {}
            feed(&mut hub, link, &mut parser, &read_p());
            let mut answered = false;
            while let Ok(bytes) = rx.try_recv() {
                let mut frames = Vec::new();
                FrameParser::new().push(&bytes, &mut frames);
                answered |= frames.iter().any(|f| matches!(f.decode(), Ok(MavMessage::PARAM_VALUE(_))));
            }
            prop_assert!(answered);
        }
    }
}
