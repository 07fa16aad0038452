//! UBX frame layout (§32.2 "UBX Frame Structure"): sync chars 0xB5 0x62, class, id, payload
//! length (u16 little-endian), payload, and the two-byte 8-bit Fletcher checksum (§32.4
//! "UBX Checksum") over class, id, length and payload.

/// First sync char, 'µ'.
pub const SYNC_1: u8 = 0xB5;
/// Second sync char, 'b'.
pub const SYNC_2: u8 = 0x62;
/// Bytes before the payload: sync (2), class, id, length (2).
pub const HEADER_LEN: usize = 6;
/// Bytes around the payload: header and checksum.
pub const OVERHEAD: usize = HEADER_LEN + 2;

/// One UBX message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UbxFrame {
    /// Message class (0x01 NAV, 0x05 ACK, 0x06 CFG, ...).
    pub class: u8,
    /// Message id within the class.
    pub id: u8,
    pub payload: Vec<u8>,
}

/// The 8-bit Fletcher checksum `(CK_A, CK_B)` of `bytes` (class through payload).
pub fn checksum(bytes: &[u8]) -> (u8, u8) {
    bytes.iter().fold((0u8, 0u8), |(a, b), &x| {
        let a = a.wrapping_add(x);
        (a, b.wrapping_add(a))
    })
}

/// The complete frame, sync to checksum, for a message. Payloads longer than 65 535 bytes
/// cannot be framed; every message this crate builds is far shorter.
pub fn encode(class: u8, id: u8, payload: &[u8]) -> Vec<u8> {
    let len = u16::try_from(payload.len()).unwrap_or(u16::MAX);
    let mut out = Vec::with_capacity(payload.len() + OVERHEAD);
    out.extend_from_slice(&[SYNC_1, SYNC_2, class, id]);
    out.extend_from_slice(&len.to_le_bytes());
    out.extend_from_slice(&payload[..usize::from(len)]);
    let (a, b) = checksum(&out[2..]);
    out.extend_from_slice(&[a, b]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_empty_poll_frame() {
        // CFG-PRT poll, as printed by u-center.
        assert_eq!(encode(0x06, 0x00, &[]), [0xB5, 0x62, 0x06, 0x00, 0x00, 0x00, 0x06, 0x18]);
    }

    #[test]
    fn the_checksum_of_an_ack() {
        // ACK-ACK of CFG-VALSET as a u-blox M10 sends it.
        let ack = [0xB5, 0x62, 0x05, 0x01, 0x02, 0x00, 0x06, 0x8A, 0x98, 0xC1];
        assert_eq!(checksum(&ack[2..8]), (0x98, 0xC1));
        assert_eq!(encode(0x05, 0x01, &[0x06, 0x8A]), ack);
    }
}
