//! Finding UBX frames in a serial byte stream.
//!
//! Bytes are buffered until a whole frame is present. Anything that is not a frame — NMEA
//! text, line noise, a frame cut short by a reconnect, a frame whose checksum fails — is
//! skipped and counted, and the search resumes one byte after the rejected sync char, so a
//! real frame hidden inside a false start is still found.

use crate::ubx::frame::{HEADER_LEN, OVERHEAD, SYNC_1, SYNC_2, UbxFrame, checksum};

/// Longest payload accepted (bytes); a longer length field is taken as a false sync. NAV-PVT
/// is 92 bytes; the longest message we use (MON-VER) is well under this.
pub const MAX_PAYLOAD: usize = 512;

/// What the parser has seen, for the driver's health report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ParserStats {
    /// Frames with a good checksum.
    pub frames: u64,
    /// Frames rejected for their checksum.
    pub checksum_errors: u64,
    /// Sync pairs followed by an impossible length.
    pub oversize: u64,
    /// Bytes dropped while looking for a sync pair.
    pub skipped_bytes: u64,
}

/// A UBX stream parser.
#[derive(Clone, Debug, Default)]
pub struct UbxParser {
    buf: Vec<u8>,
    stats: ParserStats,
}

impl UbxParser {
    pub fn new() -> UbxParser {
        UbxParser::default()
    }

    /// Counters so far.
    pub fn stats(&self) -> ParserStats {
        self.stats
    }

    /// Appends received bytes; take frames out with [`UbxParser::next_frame`].
    pub fn push(&mut self, bytes: &[u8]) {
        self.buf.extend_from_slice(bytes);
    }

    /// The next complete, checksum-valid frame in the buffer, if any.
    pub fn next_frame(&mut self) -> Option<UbxFrame> {
        loop {
            self.drop_to_sync();
            if self.buf.len() < HEADER_LEN {
                return None;
            }
            let len = usize::from(u16::from_le_bytes([self.buf[4], self.buf[5]]));
            if len > MAX_PAYLOAD {
                self.stats.oversize += 1;
                self.reject_sync();
                continue;
            }
            if self.buf.len() < len + OVERHEAD {
                return None;
            }
            let end = HEADER_LEN + len;
            if checksum(&self.buf[2..end]) != (self.buf[end], self.buf[end + 1]) {
                self.stats.checksum_errors += 1;
                self.reject_sync();
                continue;
            }
            let frame =
                UbxFrame { class: self.buf[2], id: self.buf[3], payload: self.buf[HEADER_LEN..end].to_vec() };
            self.buf.drain(..end + 2);
            self.stats.frames += 1;
            return Some(frame);
        }
    }

    /// Drops bytes up to the first possible sync pair (a trailing lone `SYNC_1` is kept).
    fn drop_to_sync(&mut self) {
        let start =
            self.buf.windows(2).position(|w| w == [SYNC_1, SYNC_2]).unwrap_or(
                if self.buf.last() == Some(&SYNC_1) { self.buf.len() - 1 } else { self.buf.len() },
            );
        self.stats.skipped_bytes += start as u64;
        self.buf.drain(..start);
    }

    /// Drops the sync char of a rejected frame so the search resumes right after it.
    fn reject_sync(&mut self) {
        self.buf.drain(..1);
        self.stats.skipped_bytes += 1;
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;
    use crate::ubx::frame::encode;

    fn nav_pvt_like() -> Vec<u8> {
        encode(0x01, 0x07, &[0x42; 92])
    }

    #[test]
    fn frames_split_across_reads_are_joined() {
        let bytes = [encode(0x05, 0x01, &[0x06, 0x8A]), nav_pvt_like()].concat();
        let mut parser = UbxParser::new();
        let mut frames = Vec::new();
        for chunk in bytes.chunks(7) {
            parser.push(chunk);
            frames.extend(std::iter::from_fn(|| parser.next_frame()));
        }
        assert_eq!(frames.len(), 2);
        assert_eq!(
            (frames[0].class, frames[0].id, frames[0].payload.as_slice()),
            (0x05, 0x01, &[0x06, 0x8A][..])
        );
        assert_eq!(parser.stats(), ParserStats { frames: 2, ..ParserStats::default() });
    }

    #[test]
    fn nmea_truncated_and_corrupt_frames_are_skipped_and_counted() {
        let mut corrupt = nav_pvt_like();
        corrupt[40] ^= 0x01;
        let truncated = &nav_pvt_like()[..50];
        let good = nav_pvt_like();
        let mut parser = UbxParser::new();
        parser.push(b"$GNGGA,173002.00,6322.46840,N,01020.45757,E,1,05,7.83,167.0,M,40.1,M,,*45\r\n");
        parser.push(&corrupt);
        parser.push(truncated);
        parser.push(&good);
        let frames: Vec<_> = std::iter::from_fn(|| parser.next_frame()).collect();
        assert_eq!(frames.len(), 1);
        assert_eq!(frames[0].payload, [0x42; 92]);
        assert_eq!(parser.stats().checksum_errors, 2);
    }

    #[test]
    fn an_absurd_length_is_a_false_sync() {
        let mut parser = UbxParser::new();
        parser.push(&[0xB5, 0x62, 0x01, 0x07, 0xFF, 0xFF]);
        parser.push(&nav_pvt_like());
        assert!(parser.next_frame().is_some());
        assert_eq!(parser.stats().oversize, 1);
    }

    proptest! {
        #[test]
        fn never_panics_and_resynchronises(garbage in proptest::collection::vec(any::<u8>(), 0..600),
                                           chunk in 1usize..64) {
            // After any garbage, enough good frames to outlast a false length field.
            let good = nav_pvt_like();
            let copies = MAX_PAYLOAD / good.len() + 2;
            let bytes = [garbage, good.repeat(copies)].concat();
            let mut parser = UbxParser::new();
            let mut frames = Vec::new();
            for piece in bytes.chunks(chunk) {
                parser.push(piece);
                frames.extend(std::iter::from_fn(|| parser.next_frame()));
            }
            prop_assert!(frames.iter().filter(|f| f.payload == [0x42; 92]).count() >= 1);
            prop_assert_eq!(frames.last().map(|f| f.payload.clone()), Some(vec![0x42; 92]));
        }
    }
}
