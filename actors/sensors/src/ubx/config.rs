//! Configuration messages sent at start-up (§32.10 "UBX-CFG"): the UART's baud rate and
//! protocols (CFG-PRT), the navigation rate (CFG-RATE), the dynamic platform model (CFG-NAV5)
//! and which messages are output (CFG-MSG). Each returns the complete frame to write.

use crate::ubx::frame::encode;

/// Class of every configuration message.
pub const CLASS_CFG: u8 = 0x06;
/// `inProtoMask`/`outProtoMask` bit: UBX.
pub const PROTO_UBX: u16 = 0x0001;
/// `inProtoMask`/`outProtoMask` bit: NMEA.
pub const PROTO_NMEA: u16 = 0x0002;

/// The platform model the receiver's navigation filter assumes (CFG-NAV5 `dynModel`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DynamicModel {
    Portable,
    Stationary,
    Pedestrian,
    Automotive,
    Sea,
    /// Airborne, < 1 g: the usual choice for multirotors.
    Airborne1g,
    /// Airborne, < 2 g.
    Airborne2g,
    /// Airborne, < 4 g: aerobatic flight.
    Airborne4g,
}

impl DynamicModel {
    /// The `dynModel` code.
    pub fn code(self) -> u8 {
        match self {
            DynamicModel::Portable => 0,
            DynamicModel::Stationary => 2,
            DynamicModel::Pedestrian => 3,
            DynamicModel::Automotive => 4,
            DynamicModel::Sea => 5,
            DynamicModel::Airborne1g => 6,
            DynamicModel::Airborne2g => 7,
            DynamicModel::Airborne4g => 8,
        }
    }
}

/// CFG-PRT (0x06 0x00) for UART `port_id` (1 = UART1): 8 data bits, no parity, 1 stop bit
/// (`mode` 0x08D0), at `baud` (bit/s), accepting `in_proto` and sending `out_proto`.
pub fn cfg_prt_uart(port_id: u8, baud: u32, in_proto: u16, out_proto: u16) -> Vec<u8> {
    let mut p = [0u8; 20];
    p[0] = port_id;
    p[4..8].copy_from_slice(&0x0000_08D0u32.to_le_bytes());
    p[8..12].copy_from_slice(&baud.to_le_bytes());
    p[12..14].copy_from_slice(&in_proto.to_le_bytes());
    p[14..16].copy_from_slice(&out_proto.to_le_bytes());
    encode(CLASS_CFG, 0x00, &p)
}

/// CFG-RATE (0x06 0x08): one measurement every `meas_ms` milliseconds (200 = 5 Hz), one
/// navigation solution per measurement, aligned to GPS time.
pub fn cfg_rate(meas_ms: u16) -> Vec<u8> {
    let mut p = [0u8; 6];
    p[0..2].copy_from_slice(&meas_ms.to_le_bytes());
    p[2..4].copy_from_slice(&1u16.to_le_bytes());
    p[4..6].copy_from_slice(&1u16.to_le_bytes());
    encode(CLASS_CFG, 0x08, &p)
}

/// CFG-NAV5 (0x06 0x24) changing only the dynamic model (`mask` bit 0, `dyn`); every other
/// setting keeps its current value.
pub fn cfg_nav5(model: DynamicModel) -> Vec<u8> {
    let mut p = [0u8; 36];
    p[0..2].copy_from_slice(&0x0001u16.to_le_bytes());
    p[2] = model.code();
    encode(CLASS_CFG, 0x24, &p)
}

/// CFG-MSG (0x06 0x01): output message `class`/`id` on the port this is sent on, once every
/// `rate` navigation solutions (0 = off).
pub fn cfg_msg(class: u8, id: u8, rate: u8) -> Vec<u8> {
    encode(CLASS_CFG, 0x01, &[class, id, rate])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ubx::frame::checksum;
    use crate::ubx::parser::UbxParser;

    fn round_trip(frame: &[u8]) -> (u8, u8, Vec<u8>) {
        let mut parser = UbxParser::new();
        parser.push(frame);
        let f = parser.next_frame().expect("valid frame");
        (f.class, f.id, f.payload)
    }

    #[test]
    fn five_hz_rate_matches_the_widely_published_command() {
        // The 5 Hz CFG-RATE string of u-center's message view (and many M8N guides).
        assert_eq!(
            cfg_rate(200),
            [0xB5, 0x62, 0x06, 0x08, 0x06, 0x00, 0xC8, 0x00, 0x01, 0x00, 0x01, 0x00, 0xDE, 0x6A]
        );
    }

    #[test]
    fn enabling_nav_pvt() {
        assert_eq!(
            cfg_msg(0x01, 0x07, 1),
            [0xB5, 0x62, 0x06, 0x01, 0x03, 0x00, 0x01, 0x07, 0x01, 0x13, 0x51]
        );
    }

    #[test]
    fn uart_at_115200_ubx_only_out() {
        let frame = cfg_prt_uart(1, 115_200, PROTO_UBX | PROTO_NMEA, PROTO_UBX);
        let (class, id, p) = round_trip(&frame);
        assert_eq!((class, id, p.len()), (0x06, 0x00, 20));
        assert_eq!(p[0], 1);
        assert_eq!(u32::from_le_bytes([p[4], p[5], p[6], p[7]]), 0x08D0);
        assert_eq!(u32::from_le_bytes([p[8], p[9], p[10], p[11]]), 115_200);
        assert_eq!((p[12], p[14]), (0x03, 0x01));
        let n = frame.len();
        assert_eq!(checksum(&frame[2..n - 2]), (frame[n - 2], frame[n - 1]));
    }

    #[test]
    fn airborne_dynamic_model() {
        let frame = cfg_nav5(DynamicModel::Airborne1g);
        let (class, id, p) = round_trip(&frame);
        assert_eq!((class, id, p.len()), (0x06, 0x24, 36));
        assert_eq!((p[0], p[1], p[2]), (0x01, 0x00, 6));
        assert!(p[3..].iter().all(|&b| b == 0));
        assert_eq!(frame[frame.len() - 2..], [0x55, 0xB4]);
    }
}
