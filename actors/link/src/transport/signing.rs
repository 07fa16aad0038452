//! MAVLink 2 signing as ArduPilot does it (`GCS_Signing.cpp`): one table of stream timestamps
//! shared by every link, so a signed frame captured on one link is a replay on every other; one
//! local timestamp (10 µs units since 2015-01-01, the spec's clock) that only moves forwards and
//! is restored at boot a minute past the stored one (see [`super::signing_store`]); unsigned
//! RADIO_STATUS accepted, as a SiK radio inserts it unsigned and telemetry thinning reads it.
//!
//! Each frame is checked exactly once, by [`LinkSigning::check`]: a second check of the same
//! frame is a replay by construction (held by
//! `a_frame_accepted_once_is_a_replay_on_any_other_link`).

use std::collections::HashMap;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{SystemTime, UNIX_EPOCH};

use mavlink::MAVLinkV2MessageRaw;
use mavlink::consts::{MAX_FRAME_SIZE, v2};
use mavlink::dialects::ardupilotmega::RADIO_STATUS_DATA;
use mavlink::{MavlinkVersion, MessageData};

use super::signing_key::SigningKey;
use crate::frame::Frame;

/// One minute in signing-timestamp units (10 µs).
pub const ONE_MINUTE: u64 = 60 * 100_000;

/// Seconds from the Unix epoch to 2015-01-01 00:00 UTC, the signing clock's epoch.
const EPOCH_2015_S: u64 = 1_420_070_400;

/// The signing clock now, from the system clock (0 when the clock is before 2015, as on a
/// board without a real-time clock before it is set; the stored timestamp then rules).
pub fn wall_timestamp() -> u64 {
    let us = SystemTime::now().duration_since(UNIX_EPOCH).map(|d| d.as_micros()).unwrap_or(0);
    let since_2015_us = us.saturating_sub(u128::from(EPOCH_2015_S) * 1_000_000);
    u64::try_from(since_2015_us / 10).unwrap_or(u64::MAX)
}

/// What the signing check made of one inbound frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Validly signed, newer than anything heard on its stream.
    Signed,
    /// Unsigned RADIO_STATUS: taken (its buffer level thins telemetry).
    UnsignedRadioStatus,
    /// Unsigned (or MAVLink 1) and not RADIO_STATUS: refused.
    Unsigned,
    /// Signed, but not with our key (or altered): refused.
    BadSignature,
    /// Validly signed, but not newer than the last frame of its stream, or (a stream not heard
    /// since boot) a minute or more older than our timestamp: refused.
    Replay,
}

impl Verdict {
    /// Whether the frame goes on to the router and the vehicle.
    pub fn accepted(self) -> bool {
        matches!(self, Verdict::Signed | Verdict::UnsignedRadioStatus)
    }
}

/// A link's signing counters (part of [`crate::hub::LinkStats`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SigningStats {
    /// Validly signed frames taken.
    pub signed_accepted: u64,
    /// Unsigned RADIO_STATUS taken.
    pub unsigned_radio_status: u64,
    /// Unsigned frames refused.
    pub unsigned_refused: u64,
    /// Frames whose signature did not match our key.
    pub bad_signature: u64,
    /// Validly signed frames refused as replays.
    pub replays: u64,
}

impl SigningStats {
    /// Counts `verdict`.
    pub fn count(&mut self, verdict: Verdict) {
        let n = match verdict {
            Verdict::Signed => &mut self.signed_accepted,
            Verdict::UnsignedRadioStatus => &mut self.unsigned_radio_status,
            Verdict::Unsigned => &mut self.unsigned_refused,
            Verdict::BadSignature => &mut self.bad_signature,
            Verdict::Replay => &mut self.replays,
        };
        *n += 1;
    }
}

/// `(link id, system id, component id)` of a signed stream, as the spec keys it.
type StreamKey = (u8, u32, u8);

#[derive(Debug)]
struct StreamState {
    /// Our timestamp: never goes back; the newest of the wall clock, the restored one, every
    /// accepted frame's and every frame we signed (+1 each).
    timestamp: u64,
    /// The newest accepted timestamp of each stream.
    streams: HashMap<StreamKey, u64>,
}

/// The signing state every link of the process shares.
#[derive(Debug)]
pub struct Streams {
    state: Mutex<StreamState>,
}

impl Streams {
    /// A table with no streams whose timestamp starts at the newer of `wall` and a minute past
    /// `stored` (ArduPilot's `load_signing_key`: the stored value may be up to its save period
    /// old, so frames signed after the last save but before the reboot are still refused).
    pub fn new(stored: Option<u64>, wall: u64) -> Streams {
        let restored = stored.map_or(0, |s| s.saturating_add(ONE_MINUTE));
        Streams { state: Mutex::new(StreamState { timestamp: restored.max(wall), streams: HashMap::new() }) }
    }

    fn lock(&self) -> MutexGuard<'_, StreamState> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Our timestamp now (what is persisted).
    pub fn timestamp(&self) -> u64 {
        self.lock().timestamp
    }

    /// Moves our timestamp forward to `t` (the wall clock, a SETUP_SIGNING's initial timestamp);
    /// never back.
    pub fn advance_to(&self, t: u64) {
        let mut s = self.lock();
        s.timestamp = s.timestamp.max(t);
    }

    /// Checks `frame` against `key` and, when it is validly signed and new, records its
    /// timestamp: the only place a stream's timestamp moves.
    pub fn check(&self, key: &[u8; 32], frame: &Frame) -> Verdict {
        let Some(raw) = signed_raw(frame) else {
            return if frame.message_id == RADIO_STATUS_DATA::ID {
                Verdict::UnsignedRadioStatus
            } else {
                Verdict::Unsigned
            };
        };
        let mut expected = [0u8; v2::SIGNATURE_VALUE_SIZE];
        raw.calculate_signature(key, &mut expected);
        if expected != raw.signature_value() {
            return Verdict::BadSignature;
        }
        let stamp = raw.signature_timestamp();
        let stream = (raw.signature_link_id(), frame.system_id, frame.component_id);
        let mut s = self.lock();
        let fresh = match s.streams.get(&stream) {
            Some(&last) => stamp > last,
            None => stamp.saturating_add(ONE_MINUTE) > s.timestamp,
        };
        if !fresh {
            return Verdict::Replay;
        }
        s.streams.insert(stream, stamp);
        s.timestamp = s.timestamp.max(stamp);
        Verdict::Signed
    }

    /// The timestamp for the next frame we sign (at least `wall`; +1 per frame, as the spec
    /// asks, so two frames never share one).
    pub fn next_send_timestamp(&self, wall: u64) -> u64 {
        let mut s = self.lock();
        let t = s.timestamp.max(wall);
        s.timestamp = t + 1;
        t
    }
}

/// The frame as a signed MAVLink 2 message, or `None` when it carries no signature.
fn signed_raw(frame: &Frame) -> Option<MAVLinkV2MessageRaw> {
    if frame.version != MavlinkVersion::V2 || !frame.signed {
        return None;
    }
    let bytes = frame.bytes();
    let mut raw = [0u8; MAX_FRAME_SIZE];
    raw.get_mut(..bytes.len())?.copy_from_slice(bytes);
    let raw = MAVLinkV2MessageRaw::from_bytes_unparsed(raw);
    (raw.incompatibility_flags() & v2::IFLAG_SIGNED != 0).then_some(raw)
}

/// One link's signing: the shared streams, its endpoint's key and the link id it signs with.
#[derive(Clone, Debug)]
pub struct LinkSigning {
    pub streams: Arc<Streams>,
    pub key: Arc<SigningKey>,
    /// The link id in the signatures we send (one per endpoint, as ArduPilot uses the channel).
    pub link_id: u8,
    /// Whether SETUP_SIGNING may install a key through this link (serial only: ArduPilot takes
    /// it over USB alone; a network link may carry anyone's frames).
    pub secure: bool,
}

impl LinkSigning {
    /// The verdict on an inbound frame (see [`Streams::check`]).
    pub fn check(&self, frame: &Frame) -> Verdict {
        self.streams.check(&self.key.get(), frame)
    }

    /// Signs `raw` (serialised with `serialize_message_for_signing`) with our key, link id and
    /// the next timestamp.
    pub fn sign(&self, raw: &mut MAVLinkV2MessageRaw) {
        let stamp = self.streams.next_send_timestamp(wall_timestamp());
        *raw.signature_link_id_mut() = self.link_id;
        raw.signature_timestamp_bytes_mut()
            .copy_from_slice(&stamp.to_le_bytes()[..v2::SIGNATURE_TIMESTAMP_SIZE]);
        let mut value = [0u8; v2::SIGNATURE_VALUE_SIZE];
        raw.calculate_signature(&self.key.get(), &mut value);
        raw.signature_value_mut().copy_from_slice(&value);
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use mavlink::dialects::ardupilotmega::{HEARTBEAT_DATA, MavMessage};
    use mavlink::{MAVLinkV2MessageRaw, MavHeader};
    use proptest::prelude::*;

    use super::*;
    use crate::frame::{FrameParser, encode, encode_v1};

    pub(crate) const KEY: [u8; 32] = [7; 32];

    /// A frame signed by a ground station (system 255, component 190) on its link `link_id` at
    /// `stamp`, with the independent signer of the `mavlink` crate.
    pub(crate) fn gcs_frame(key: [u8; 32], link_id: u8, stamp: u64, msg: &MavMessage) -> Frame {
        let signer =
            mavlink::SigningData::from_config(mavlink::SigningConfig::new(key, link_id, true, false));
        let mut raw = MAVLinkV2MessageRaw::new();
        raw.serialize_message_for_signing(MavHeader { system_id: 255, component_id: 190, sequence: 0 }, msg);
        signer.sign_message(&mut raw);
        // The crate stamps with the wall clock; restamp and re-sign for a chosen timestamp.
        raw.signature_timestamp_bytes_mut().copy_from_slice(&stamp.to_le_bytes()[..6]);
        let mut value = [0u8; 6];
        raw.calculate_signature(&key, &mut value);
        raw.signature_value_mut().copy_from_slice(&value);
        parse(raw.raw_bytes())
    }

    pub(crate) fn parse(bytes: &[u8]) -> Frame {
        let mut frames = Vec::new();
        FrameParser::new().push(bytes, &mut frames);
        assert_eq!(frames.len(), 1);
        frames.remove(0)
    }

    fn heartbeat() -> MavMessage {
        MavMessage::HEARTBEAT(HEARTBEAT_DATA::default())
    }

    fn radio_status() -> MavMessage {
        MavMessage::RADIO_STATUS(RADIO_STATUS_DATA { txbuf: 10, ..Default::default() })
    }

    const T0: u64 = 400_000_000_000;

    #[test]
    fn a_frame_accepted_once_is_a_replay_on_any_other_link() {
        let streams = Arc::new(Streams::new(None, T0));
        let frame = gcs_frame(KEY, 3, T0 + 10, &heartbeat());
        assert_eq!(streams.check(&KEY, &frame), Verdict::Signed);
        // Whichever link it comes in on next, the shared table has seen it.
        assert_eq!(streams.check(&KEY, &frame), Verdict::Replay);
        assert_eq!(streams.check(&KEY, &gcs_frame(KEY, 3, T0 + 9, &heartbeat())), Verdict::Replay);
        assert_eq!(streams.check(&KEY, &gcs_frame(KEY, 3, T0 + 11, &heartbeat())), Verdict::Signed);
        // Another link id of the same ground station is another stream.
        assert_eq!(streams.check(&KEY, &gcs_frame(KEY, 4, T0 + 5, &heartbeat())), Verdict::Signed);
    }

    #[test]
    fn after_a_restart_frames_signed_before_the_stored_timestamp_are_replays() {
        // The run before the restart accepted the frame and stored the timestamp it reached.
        let before = Streams::new(None, T0);
        let captured = gcs_frame(KEY, 0, T0 + 100, &heartbeat());
        assert_eq!(before.check(&KEY, &captured), Verdict::Signed);
        let stored = before.timestamp();
        // Rebooted without a real-time clock: the wall clock reads 1970 (0).
        let after = Streams::new(Some(stored), 0);
        assert_eq!(after.timestamp(), stored + ONE_MINUTE, "restored a minute past the stored value");
        assert_eq!(after.check(&KEY, &captured), Verdict::Replay);
        assert_eq!(after.check(&KEY, &gcs_frame(KEY, 0, stored + 1, &heartbeat())), Verdict::Signed);
        // With a clock ahead of the stored value, the clock rules; never the older one.
        assert_eq!(Streams::new(Some(stored), stored + 5 * ONE_MINUTE).timestamp(), stored + 5 * ONE_MINUTE);
    }

    #[test]
    fn only_radio_status_is_taken_unsigned() {
        let streams = Streams::new(None, T0);
        let header = MavHeader { system_id: 51, component_id: 68, sequence: 0 };
        assert_eq!(
            streams.check(&KEY, &parse(&encode(header, &radio_status(), None))),
            Verdict::UnsignedRadioStatus
        );
        assert_eq!(
            streams.check(&KEY, &parse(&encode_v1(header, &radio_status()))),
            Verdict::UnsignedRadioStatus
        );
        assert_eq!(streams.check(&KEY, &parse(&encode(header, &heartbeat(), None))), Verdict::Unsigned);
        assert_eq!(streams.check(&KEY, &parse(&encode_v1(header, &heartbeat()))), Verdict::Unsigned);
        assert!(Verdict::UnsignedRadioStatus.accepted() && !Verdict::Unsigned.accepted());
    }

    #[test]
    fn a_wrong_key_or_an_altered_frame_is_a_bad_signature_and_leaves_the_stream_alone() {
        let streams = Streams::new(None, T0);
        assert_eq!(streams.check(&KEY, &gcs_frame([8; 32], 0, T0 + 50, &heartbeat())), Verdict::BadSignature);
        let good = gcs_frame(KEY, 0, T0 + 50, &heartbeat());
        let mut bytes = good.bytes().to_vec();
        let n = bytes.len();
        bytes[n - 1] ^= 1;
        assert_eq!(streams.check(&KEY, &parse(&bytes)), Verdict::BadSignature);
        // The refused frames moved nothing: the genuine one is still new.
        assert_eq!(streams.check(&KEY, &good), Verdict::Signed);
    }

    #[test]
    fn a_new_stream_a_minute_older_than_our_clock_is_refused() {
        let streams = Streams::new(None, T0);
        assert_eq!(streams.check(&KEY, &gcs_frame(KEY, 0, T0 - ONE_MINUTE, &heartbeat())), Verdict::Replay);
        assert_eq!(
            streams.check(&KEY, &gcs_frame(KEY, 0, T0 - ONE_MINUTE + 1, &heartbeat())),
            Verdict::Signed
        );
    }

    #[test]
    fn what_we_sign_verifies_with_an_independent_verifier_and_stamps_rise() {
        let key = Arc::new(SigningKey::for_tests(KEY));
        let link = LinkSigning { streams: Arc::new(Streams::new(None, T0)), key, link_id: 2, secure: false };
        let header = MavHeader { system_id: 1, component_id: 1, sequence: 0 };
        let a = parse(&encode(header, &heartbeat(), Some(&link)));
        let b = parse(&encode(header, &heartbeat(), Some(&link)));
        let verifier = mavlink::SigningData::from_config(mavlink::SigningConfig::new(KEY, 0, true, false));
        for f in [&a, &b] {
            let mut raw = [0u8; MAX_FRAME_SIZE];
            raw[..f.bytes().len()].copy_from_slice(f.bytes());
            assert!(verifier.verify_signature(&MAVLinkV2MessageRaw::from_bytes_unparsed(raw)));
        }
        let stamp = |f: &Frame| signed_raw(f).map(|r| (r.signature_link_id(), r.signature_timestamp()));
        let (sa, sb) = (stamp(&a).expect("signed"), stamp(&b).expect("signed"));
        assert_eq!((sa.0, sb.0), (2, 2));
        assert!(sb.1 > sa.1 && sa.1 >= T0);
    }

    proptest! {
        /// Whatever order frames of one stream arrive in, each timestamp is taken at most once
        /// and the accepted ones rise.
        #[test]
        fn each_stamp_is_taken_at_most_once_and_accepted_stamps_rise(
            offsets in proptest::collection::vec(0u64..50, 1..40),
        ) {
            let streams = Streams::new(None, T0);
            let mut accepted = Vec::new();
            for o in offsets {
                if streams.check(&KEY, &gcs_frame(KEY, 0, T0 + o, &heartbeat())) == Verdict::Signed {
                    accepted.push(o);
                }
            }
            prop_assert!(accepted.windows(2).all(|w| w[1] > w[0]));
            prop_assert!(streams.timestamp() >= T0 + accepted.last().copied().unwrap_or(0));
        }
    }
}
