//! ArduPilot SITL's servo packet, the request half of its JSON physics protocol
//! (`libraries/SITL/SIM_JSON.h` in the ArduPilot tree).
//!
//! Little-endian and packed: `magic: u16`, `frame_rate: u16` (Hz), `frame_count: u32`, then
//! `pwm: [u16; 16]` (µs) — or `[u16; 32]` with the other magic when `SERVO_32_ENABLE` is set. A
//! packet of any other length or magic is refused whole: a torn or foreign datagram must not
//! reach the motors (`packet_of_the_wrong_length_or_magic_is_refused`).

use thiserror::Error;

/// Magic of a 16-channel packet.
pub const MAGIC_16: u16 = 18458;
/// Magic of a 32-channel packet (`SERVO_32_ENABLE = 1`).
pub const MAGIC_32: u16 = 29569;
/// Most channels a packet carries.
pub const MAX_CHANNELS: usize = 32;
/// Bytes before the PWM values.
const HEADER_BYTES: usize = 8;

/// One servo packet from SITL.
#[derive(Clone, Debug, PartialEq)]
pub struct ServoPacket {
    /// SITL's physics frame rate (Hz), > 0.
    pub frame_rate_hz: u16,
    /// Counts up by one per physics frame; a repeat is SITL sending the same frame again after
    /// a second without an answer.
    pub frame_count: u32,
    /// Pulse widths in channel order (µs); channels past `channels` are 0.
    pub pwm_us: [u16; MAX_CHANNELS],
    /// 16 or 32.
    pub channels: usize,
}

/// Why a datagram is not a servo packet.
#[derive(Clone, Debug, PartialEq, Error)]
pub enum PacketError {
    #[error("servo packet of {len} bytes: expected {HEADER_BYTES} + 2·16 or 2·32 with the matching magic")]
    Length { len: usize },
    #[error("servo packet magic {magic}: expected {MAGIC_16} (16 channels) or {MAGIC_32} (32 channels)")]
    Magic { magic: u16 },
    #[error("servo packet of {len} bytes does not match its magic {magic}")]
    LengthForMagic { len: usize, magic: u16 },
    #[error("servo packet frame_rate 0 Hz: SITL always sends its positive physics rate")]
    FrameRate,
}

impl ServoPacket {
    /// Parses one datagram; every field is checked.
    pub fn parse(bytes: &[u8]) -> Result<ServoPacket, PacketError> {
        let len = bytes.len();
        if len < HEADER_BYTES {
            return Err(PacketError::Length { len });
        }
        let u16_at = |i: usize| u16::from_le_bytes([bytes[i], bytes[i + 1]]);
        let magic = u16_at(0);
        let channels = match magic {
            MAGIC_16 => 16,
            MAGIC_32 => 32,
            _ => return Err(PacketError::Magic { magic }),
        };
        if len != HEADER_BYTES + 2 * channels {
            return Err(if len == HEADER_BYTES + 32 || len == HEADER_BYTES + 64 {
                PacketError::LengthForMagic { len, magic }
            } else {
                PacketError::Length { len }
            });
        }
        let frame_rate_hz = u16_at(2);
        if frame_rate_hz == 0 {
            return Err(PacketError::FrameRate);
        }
        let frame_count = u32::from_le_bytes([bytes[4], bytes[5], bytes[6], bytes[7]]);
        let mut pwm_us = [0; MAX_CHANNELS];
        for (i, pwm) in pwm_us.iter_mut().take(channels).enumerate() {
            *pwm = u16_at(HEADER_BYTES + 2 * i);
        }
        Ok(ServoPacket { frame_rate_hz, frame_count, pwm_us, channels })
    }

    /// The packet's bytes, as SITL writes them (for tests and tools that play SITL's part).
    pub fn to_bytes(&self) -> Vec<u8> {
        let magic = if self.channels == 32 { MAGIC_32 } else { MAGIC_16 };
        let mut bytes = Vec::with_capacity(HEADER_BYTES + 2 * self.channels);
        bytes.extend_from_slice(&magic.to_le_bytes());
        bytes.extend_from_slice(&self.frame_rate_hz.to_le_bytes());
        bytes.extend_from_slice(&self.frame_count.to_le_bytes());
        for pwm in &self.pwm_us[..self.channels] {
            bytes.extend_from_slice(&pwm.to_le_bytes());
        }
        bytes
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn packet(pwm: &[u16]) -> ServoPacket {
        let mut pwm_us = [0; MAX_CHANNELS];
        pwm_us[..pwm.len()].copy_from_slice(pwm);
        ServoPacket { frame_rate_hz: 1200, frame_count: 7, pwm_us, channels: 16 }
    }

    #[test]
    fn a_sixteen_channel_packet_reads_back_field_by_field() {
        // Bytes laid out by hand as `<HHI16H`: 18458, 1200, 7, 1100, 1200, 0...
        let mut bytes = vec![0x1a, 0x48, 0xb0, 0x04, 7, 0, 0, 0, 0x4c, 0x04, 0xb0, 0x04];
        bytes.resize(8 + 32, 0);
        let parsed = ServoPacket::parse(&bytes).unwrap();
        assert_eq!(parsed, packet(&[1100, 1200]));
        assert_eq!(parsed.to_bytes(), bytes);
    }

    #[test]
    fn a_thirty_two_channel_packet_carries_every_channel() {
        let mut sent = packet(&[1500; 32]);
        sent.channels = 32;
        let bytes = sent.to_bytes();
        assert_eq!(bytes.len(), 72);
        assert_eq!(u16::from_le_bytes([bytes[0], bytes[1]]), MAGIC_32);
        assert_eq!(ServoPacket::parse(&bytes).unwrap(), sent);
    }

    #[test]
    fn packet_of_the_wrong_length_or_magic_is_refused() {
        let bytes = packet(&[1500; 4]).to_bytes();
        assert_eq!(ServoPacket::parse(&bytes[..39]), Err(PacketError::Length { len: 39 }));
        assert_eq!(ServoPacket::parse(&bytes[..3]), Err(PacketError::Length { len: 3 }));
        let mut foreign = bytes.clone();
        foreign[0] = 0;
        assert!(matches!(ServoPacket::parse(&foreign), Err(PacketError::Magic { .. })));
        let mut long = bytes.clone();
        long.resize(72, 0);
        assert_eq!(ServoPacket::parse(&long), Err(PacketError::LengthForMagic { len: 72, magic: MAGIC_16 }));
        let mut still = bytes;
        still[2] = 0;
        still[3] = 0;
        assert_eq!(ServoPacket::parse(&still), Err(PacketError::FrameRate));
    }
}
