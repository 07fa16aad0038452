//! The SBUS frame: header 0x0F, 22 bytes packing 16 channels of 11 bits least significant bit
//! first, a flags byte (bit 0 digital channel 17, bit 1 channel 18, bit 2 frame lost, bit 3
//! failsafe) and a footer: 0x00, or for SBUS2 receivers 0x04/0x14/0x24/0x34 (telemetry slot).
//! A frame is sent every 7 ms (high speed) or 14 ms.

/// Bytes in a frame.
pub const FRAME_LEN: usize = 25;
/// First byte of every frame.
pub const HEADER: u8 = 0x0F;
/// Proportional channels per frame.
pub const CHANNELS: usize = 16;

/// Why bytes were not a frame.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SbusError {
    #[error("SBUS frame starts with {0:#04x}, expected 0x0f")]
    Header(u8),
    #[error("SBUS frame ends with {0:#04x}, expected 0x00 or an SBUS2 footer")]
    Footer(u8),
}

/// One decoded frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SbusFrame {
    /// Channel values, 11 bits each (0..2047; FrSky/Futaba sticks span about 172..1811).
    pub channels: [u16; CHANNELS],
    /// Digital channels 17 and 18.
    pub digital: [bool; 2],
    /// The receiver missed the transmitter's last frame; the channels hold older values.
    pub frame_lost: bool,
    /// The receiver has lost the link and is sending its failsafe values.
    pub failsafe: bool,
}

fn is_footer(b: u8) -> bool {
    b == 0x00 || b & 0x0F == 0x04
}

impl SbusFrame {
    /// Decodes one frame.
    pub fn decode(bytes: &[u8; FRAME_LEN]) -> Result<SbusFrame, SbusError> {
        if bytes[0] != HEADER {
            return Err(SbusError::Header(bytes[0]));
        }
        if !is_footer(bytes[24]) {
            return Err(SbusError::Footer(bytes[24]));
        }
        let mut channels = [0u16; CHANNELS];
        for (ch, value) in channels.iter_mut().enumerate() {
            let bit = ch * 11;
            let byte = 1 + bit / 8;
            let word = u32::from(bytes[byte])
                | u32::from(bytes[byte + 1]) << 8
                | bytes.get(byte + 2).filter(|_| byte + 2 < 23).map_or(0, |&b| u32::from(b) << 16);
            *value = ((word >> (bit % 8)) & 0x07FF) as u16;
        }
        let flags = bytes[23];
        Ok(SbusFrame {
            channels,
            digital: [flags & 0x01 != 0, flags & 0x02 != 0],
            frame_lost: flags & 0x04 != 0,
            failsafe: flags & 0x08 != 0,
        })
    }

    /// Encodes the frame (footer 0x00): the inverse of [`SbusFrame::decode`], for tests and
    /// for simulating a receiver.
    pub fn encode(&self) -> [u8; FRAME_LEN] {
        let mut out = [0u8; FRAME_LEN];
        out[0] = HEADER;
        for (ch, &value) in self.channels.iter().enumerate() {
            let bit = ch * 11;
            let word = u32::from(value & 0x07FF) << (bit % 8);
            for k in 0..3 {
                let byte = 1 + bit / 8 + k;
                if byte < 23 {
                    out[byte] |= (word >> (8 * k)) as u8;
                }
            }
        }
        out[23] = u8::from(self.digital[0])
            | u8::from(self.digital[1]) << 1
            | u8::from(self.frame_lost) << 2
            | u8::from(self.failsafe) << 3;
        out
    }
}

/// Finds frames in the serial byte stream, counting what it skips.
///
/// A header byte and a footer 24 bytes on are weak evidence (0x0F and 0x00 are common channel
/// bytes), so until the parser is in step with the stream it also wants the next frame's
/// header right after a candidate. Once a frame has been confirmed that way, each following
/// frame that starts where the last one ended is taken as soon as its 25 bytes are in; any
/// skipped byte or rejected candidate puts the parser out of step again.
#[derive(Clone, Debug, Default)]
pub struct SbusParser {
    buf: Vec<u8>,
    /// The buffer starts where the last accepted frame ended.
    in_step: bool,
    /// Frames decoded.
    pub frames: u64,
    /// Bytes dropped while looking for a header followed, 24 bytes on, by a footer.
    pub skipped_bytes: u64,
    /// Header bytes not followed by a footer (or, out of step, by the next header): line
    /// noise, a cut frame, or a 0x0F inside a frame found while resynchronising.
    pub rejected: u64,
}

impl SbusParser {
    pub fn new() -> SbusParser {
        SbusParser::default()
    }

    /// Appends received bytes; take frames out with [`SbusParser::next_frame`].
    pub fn push(&mut self, bytes: &[u8]) {
        self.buf.extend_from_slice(bytes);
    }

    /// The next well-framed frame in the buffer, if any.
    pub fn next_frame(&mut self) -> Option<SbusFrame> {
        loop {
            let start = self.buf.iter().position(|&b| b == HEADER).unwrap_or(self.buf.len());
            if start > 0 {
                self.in_step = false;
            }
            self.skipped_bytes += start as u64;
            self.buf.drain(..start);
            if self.buf.len() < FRAME_LEN {
                return None;
            }
            let mut frame = [0u8; FRAME_LEN];
            frame.copy_from_slice(&self.buf[..FRAME_LEN]);
            let confirmed = self.in_step || self.buf.get(FRAME_LEN) == Some(&HEADER);
            match SbusFrame::decode(&frame) {
                Ok(_) if !confirmed && self.buf.len() == FRAME_LEN => return None,
                Ok(decoded) if confirmed => {
                    self.buf.drain(..FRAME_LEN);
                    self.frames += 1;
                    self.in_step = true;
                    return Some(decoded);
                }
                Ok(_) | Err(_) => {
                    self.buf.drain(..1);
                    self.skipped_bytes += 1;
                    self.rejected += 1;
                    self.in_step = false;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    #[test]
    fn a_frame_with_all_channels_at_1024() {
        // 16 × 0x400 packed LSB first: the pattern 00 04 20 00 01 08 40 00 02 10 80 repeats.
        let mut bytes = [0u8; FRAME_LEN];
        bytes[0] = HEADER;
        let pattern = [0x00, 0x04, 0x20, 0x00, 0x01, 0x08, 0x40, 0x00, 0x02, 0x10, 0x80];
        for (i, b) in bytes[1..23].iter_mut().enumerate() {
            *b = pattern[i % pattern.len()];
        }
        bytes[23] = 0x0C;
        let frame = SbusFrame::decode(&bytes).expect("valid");
        assert_eq!(frame.channels, [1024; CHANNELS]);
        assert!(frame.frame_lost && frame.failsafe);
        assert_eq!(frame.digital, [false, false]);
        assert_eq!(frame.encode(), bytes);
    }

    #[test]
    fn bad_header_and_footer() {
        let mut bytes =
            SbusFrame { channels: [992; 16], digital: [true, false], frame_lost: false, failsafe: false }
                .encode();
        bytes[24] = 0x14;
        assert!(SbusFrame::decode(&bytes).is_ok(), "SBUS2 footer");
        bytes[24] = 0x55;
        assert_eq!(SbusFrame::decode(&bytes), Err(SbusError::Footer(0x55)));
        bytes[0] = 0x00;
        assert_eq!(SbusFrame::decode(&bytes), Err(SbusError::Header(0x00)));
    }

    #[test]
    fn a_false_header_in_noise_does_not_shift_the_frames() {
        let good =
            SbusFrame { channels: [1811; 16], digital: [false; 2], frame_lost: false, failsafe: false };
        // 0x0F noise right before a frame: header at 0x0F, footer at the frame's flags byte.
        let bytes = [&[0x0F, 0x42, 0x0F][..], &good.encode(), &good.encode()].concat();
        let mut parser = SbusParser::new();
        parser.push(&bytes);
        let frames: Vec<_> = std::iter::from_fn(|| parser.next_frame()).collect();
        assert_eq!(frames, [good, good]);
        assert_eq!(parser.rejected, 2);
    }

    proptest! {
        #[test]
        fn channels_round_trip(channels in proptest::array::uniform16(0u16..2048), flags in 0u8..16) {
            let frame = SbusFrame {
                channels,
                digital: [flags & 1 != 0, flags & 2 != 0],
                frame_lost: flags & 4 != 0,
                failsafe: flags & 8 != 0,
            };
            prop_assert_eq!(SbusFrame::decode(&frame.encode()), Ok(frame));
        }

        #[test]
        fn the_parser_never_panics_and_finds_frames_after_garbage(
            garbage in proptest::collection::vec(any::<u8>(), 0..200),
            chunk in 1usize..30,
        ) {
            let good = SbusFrame { channels: [1500; 16], digital: [false; 2], frame_lost: false, failsafe: false };
            let bytes = [garbage, good.encode().repeat(3)].concat();
            let mut parser = SbusParser::new();
            let mut frames = Vec::new();
            for piece in bytes.chunks(chunk) {
                parser.push(piece);
                frames.extend(std::iter::from_fn(|| parser.next_frame()));
            }
            prop_assert_eq!(frames.last(), Some(&good));
        }
    }
}
