//! MAVLink frames on the wire: a streaming parser that accepts MAVLink 1 and 2 (resynchronising
//! after garbage and counting every frame it refuses), and the encoder for what we send.

use mavlink::consts::{CHECKSUM_SIZE, v2};
use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::error::ParserError;
use mavlink::{MAV_STX, MAV_STX_V2, MAVLinkV2MessageRaw, MavHeader, MavlinkVersion, Message};

use crate::transport::LinkSigning;

/// MAVLink 1 header length after the start byte: len, seq, sysid, compid, msgid.
const V1_HEADER: usize = 5;

/// One complete, checksum-verified frame as it arrived.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Frame {
    pub version: MavlinkVersion,
    pub sequence: u8,
    pub system_id: u32,
    pub component_id: u8,
    pub message_id: u32,
    /// Whether the frame carries a MAVLink 2 signature (not yet verified).
    pub signed: bool,
    /// Where the payload starts in `bytes`.
    payload_start: usize,
    payload_len: usize,
    /// The whole frame, start byte to signature, forwarded untouched by the router.
    bytes: Vec<u8>,
}

impl Frame {
    /// The frame as received.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// The (possibly zero-trimmed) payload.
    pub fn payload(&self) -> &[u8] {
        &self.bytes[self.payload_start..self.payload_start + self.payload_len]
    }

    /// The message this frame carries.
    pub fn decode(&self) -> Result<MavMessage, ParserError> {
        MavMessage::parse(self.version, self.message_id, self.payload())
    }
}

/// What a parser has refused so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ParseStats {
    /// Frames accepted.
    pub frames: u64,
    /// Frames whose checksum did not match.
    pub bad_crc: u64,
    /// Frames with a message id outside our dialect (their checksum cannot be checked).
    pub unknown_message: u64,
    /// MAVLink 2 frames with incompatibility flags we do not understand.
    pub bad_flags: u64,
    /// Bytes skipped while looking for a start byte.
    pub skipped_bytes: u64,
}

/// Splits a byte stream (or a datagram) into frames.
#[derive(Debug, Default)]
pub struct FrameParser {
    buf: Vec<u8>,
    stats: ParseStats,
}

impl FrameParser {
    /// A parser with nothing buffered.
    pub fn new() -> FrameParser {
        FrameParser::default()
    }

    /// Counters since the parser was made.
    pub fn stats(&self) -> ParseStats {
        self.stats
    }

    /// Feeds `data`, appending every complete valid frame to `out`. A partial frame at the end
    /// stays buffered for the next call.
    pub fn push(&mut self, data: &[u8], out: &mut Vec<Frame>) {
        self.buf.extend_from_slice(data);
        let mut start = 0;
        loop {
            let rest = &self.buf[start..];
            let Some(stx) = rest.iter().position(|&b| b == MAV_STX || b == MAV_STX_V2) else {
                self.stats.skipped_bytes += rest.len() as u64;
                start = self.buf.len();
                break;
            };
            self.stats.skipped_bytes += stx as u64;
            start += stx;
            match self.try_frame(start) {
                Step::NeedMore => break,
                Step::Reject => start += 1,
                Step::Frame(frame) => {
                    start += frame.bytes.len();
                    self.stats.frames += 1;
                    out.push(frame);
                }
            }
        }
        self.buf.drain(..start);
    }

    fn try_frame(&mut self, start: usize) -> Step {
        let b = &self.buf[start..];
        if b.len() < 3 {
            return Step::NeedMore;
        }
        let payload_len = usize::from(b[1]);
        let (version, header_len, signed) = if b[0] == MAV_STX {
            (MavlinkVersion::V1, V1_HEADER, false)
        } else {
            let flags = b[2];
            if flags & !v2::SUPPORTED_IFLAGS != 0 {
                self.stats.bad_flags += 1;
                return Step::Reject;
            }
            let header = v2::MIN_HEADER_SIZE
                + if flags & v2::IFLAG_SYSID32 != 0 { v2::SYSID32_EXTRA_HEADER_SIZE } else { 0 };
            (MavlinkVersion::V2, header, flags & v2::IFLAG_SIGNED != 0)
        };
        let crc_end = 1 + header_len + payload_len;
        let total = crc_end + CHECKSUM_SIZE + if signed { v2::SIGNATURE_SIZE } else { 0 };
        if b.len() < total {
            return Step::NeedMore;
        }
        let h = &b[1..1 + header_len];
        let (sequence, system_id, component_id, message_id) = match version {
            MavlinkVersion::V1 => (h[1], u32::from(h[2]), h[3], u32::from(h[4])),
            MavlinkVersion::V2 if header_len == v2::MIN_HEADER_SIZE => {
                (h[3], u32::from(h[4]), h[5], u32::from_le_bytes([h[6], h[7], h[8], 0]))
            }
            MavlinkVersion::V2 => (
                h[3],
                u32::from_le_bytes([h[4], h[5], h[6], h[7]]),
                h[8],
                u32::from_le_bytes([h[9], h[10], h[11], 0]),
            ),
        };
        let extra = MavMessage::extra_crc(message_id);
        if extra == 0 && MavMessage::default_message_from_id(message_id).is_none() {
            self.stats.unknown_message += 1;
            return Step::Reject;
        }
        let crc = mavlink::calculate_crc(&b[1..crc_end], extra);
        if crc != u16::from_le_bytes([b[crc_end], b[crc_end + 1]]) {
            self.stats.bad_crc += 1;
            return Step::Reject;
        }
        Step::Frame(Frame {
            version,
            sequence,
            system_id,
            component_id,
            message_id,
            signed,
            payload_start: 1 + header_len,
            payload_len,
            bytes: b[..total].to_vec(),
        })
    }
}

enum Step {
    NeedMore,
    Reject,
    Frame(Frame),
}

/// Serialises `msg` as a MAVLink 2 frame from `header`, signed when `signing` is given.
pub fn encode(header: MavHeader, msg: &MavMessage, signing: Option<&LinkSigning>) -> Vec<u8> {
    let mut raw = MAVLinkV2MessageRaw::new();
    match signing {
        Some(signing) => {
            raw.serialize_message_for_signing(header, msg);
            signing.sign(&mut raw);
        }
        None => raw.serialize_message(header, msg),
    }
    raw.raw_bytes().to_vec()
}

/// Serialises `msg` as a MAVLink 1 frame (for tests and MAVLink 1 peers).
pub fn encode_v1(header: MavHeader, msg: &MavMessage) -> Vec<u8> {
    let mut raw = mavlink::MAVLinkV1MessageRaw::new();
    raw.serialize_message(header, msg);
    raw.raw_bytes().to_vec()
}

#[cfg(test)]
mod tests {
    use mavlink::dialects::ardupilotmega::{HEARTBEAT_DATA, PARAM_REQUEST_LIST_DATA};
    use proptest::prelude::*;

    use super::*;

    fn header(seq: u8) -> MavHeader {
        MavHeader { system_id: 255, component_id: 190, sequence: seq }
    }

    fn heartbeat() -> MavMessage {
        MavMessage::HEARTBEAT(HEARTBEAT_DATA::default())
    }

    fn parse_all(bytes: &[u8]) -> (Vec<Frame>, ParseStats) {
        let mut p = FrameParser::new();
        let mut out = Vec::new();
        p.push(bytes, &mut out);
        (out, p.stats())
    }

    #[test]
    fn parses_v1_and_v2_and_decodes() {
        let mut bytes = encode_v1(header(1), &heartbeat());
        let req =
            MavMessage::PARAM_REQUEST_LIST(PARAM_REQUEST_LIST_DATA { target_system: 1, target_component: 1 });
        bytes.extend(encode(header(2), &req, None));
        let (frames, stats) = parse_all(&bytes);
        assert_eq!(frames.len(), 2, "{stats:?}");
        assert_eq!(frames[0].version, MavlinkVersion::V1);
        assert_eq!(frames[1].version, MavlinkVersion::V2);
        assert_eq!((frames[1].system_id, frames[1].component_id, frames[1].sequence), (255, 190, 2));
        assert_eq!(frames[1].decode().ok(), Some(req));
    }

    #[test]
    fn byte_at_a_time_gives_the_same_frames() {
        let bytes: Vec<u8> = (0..5).flat_map(|i| encode(header(i), &heartbeat(), None)).collect();
        let mut p = FrameParser::new();
        let mut out = Vec::new();
        for b in &bytes {
            p.push(std::slice::from_ref(b), &mut out);
        }
        assert_eq!(out.len(), 5);
    }

    #[test]
    fn bad_crc_is_counted_and_the_next_frame_still_parses() {
        let mut bad = encode(header(1), &heartbeat(), None);
        let n = bad.len();
        bad[n - 1] ^= 0xff;
        bad.extend(b"garbage");
        bad.extend(encode(header(2), &heartbeat(), None));
        let (frames, stats) = parse_all(&bad);
        assert_eq!(frames.len(), 1);
        assert_eq!(frames[0].sequence, 2);
        assert_eq!(stats.bad_crc, 1);
    }

    proptest! {
        #[test]
        fn random_and_mutated_input_never_panics(
            noise in proptest::collection::vec(any::<u8>(), 0..600),
            flip in any::<(usize, u8)>(),
        ) {
            let mut bytes = encode(header(9), &heartbeat(), None);
            let i = flip.0 % bytes.len();
            bytes[i] ^= flip.1;
            bytes.extend(&noise);
            bytes.extend(encode(header(10), &heartbeat(), None));
            let (frames, _) = parse_all(&bytes);
            prop_assert!(frames.len() <= 2);
        }
    }
}
