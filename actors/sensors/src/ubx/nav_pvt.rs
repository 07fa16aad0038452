//! UBX-NAV-PVT (0x01 0x07), the receiver's navigation solution (§32.17.15 "UBX-NAV-PVT
//! (0x01 0x07)"), decoded into SI units and mapped onto [`GpsFix`].

use kestrel_proto::Time;
use kestrel_proto::geo::deg_from_e7;
use kestrel_proto::messages::{GpsFix, GpsFixType};

use crate::ubx::frame::UbxFrame;

/// Message class of NAV-PVT.
pub const CLASS: u8 = 0x01;
/// Message id of NAV-PVT.
pub const ID: u8 = 0x07;
/// Payload length of NAV-PVT (bytes).
pub const LEN: usize = 92;

/// Why a frame is not a usable NAV-PVT.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum NavPvtError {
    #[error("not NAV-PVT: class {class:#04x} id {id:#04x}")]
    WrongMessage { class: u8, id: u8 },
    #[error("NAV-PVT payload is {0} bytes, expected {LEN}")]
    Length(usize),
}

/// A decoded NAV-PVT solution, in SI units.
#[derive(Clone, Debug, PartialEq)]
pub struct NavPvt {
    /// GPS time of week of the navigation epoch (ms); the solution's time of validity.
    pub itow_ms: u32,
    /// UTC date and time of day are valid (`valid` bits 0 and 1).
    pub utc_valid: bool,
    /// UTC `[year, month, day, hour, minute, second]`.
    pub utc: [u16; 6],
    /// Raw `fixType`: 0 none, 1 dead reckoning only, 2 2-D, 3 3-D, 4 GNSS + dead reckoning,
    /// 5 time only.
    pub fix_type_raw: u8,
    /// `flags` bit 0, gnssFixOK: the fix is within the configured DOP and accuracy masks.
    pub gnss_fix_ok: bool,
    /// `flags` bit 1, diffSoln: differential corrections were applied.
    pub diff_soln: bool,
    /// `flags` bits 6..7, carrSoln: 0 none, 1 float, 2 fixed RTK.
    pub carr_soln: u8,
    /// Satellites used in the solution.
    pub num_sv: u8,
    /// Latitude (degrees).
    pub lat_deg: f64,
    /// Longitude (degrees).
    pub lon_deg: f64,
    /// Height above the WGS-84 ellipsoid (m).
    pub height_ellipsoid_m: f64,
    /// Height above mean sea level (m).
    pub height_msl_m: f64,
    /// Horizontal accuracy estimate (m).
    pub h_acc_m: f64,
    /// Vertical accuracy estimate (m).
    pub v_acc_m: f64,
    /// Velocity north, east, down (m/s).
    pub vel_ned_m_s: [f64; 3],
    /// Speed accuracy estimate (m/s).
    pub s_acc_m_s: f64,
    /// Position dilution of precision.
    pub pdop: f64,
}

fn u32_at(p: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([p[at], p[at + 1], p[at + 2], p[at + 3]])
}

fn i32_at(p: &[u8], at: usize) -> i32 {
    i32::from_le_bytes([p[at], p[at + 1], p[at + 2], p[at + 3]])
}

impl NavPvt {
    /// Decodes a NAV-PVT frame.
    pub fn decode(frame: &UbxFrame) -> Result<NavPvt, NavPvtError> {
        if (frame.class, frame.id) != (CLASS, ID) {
            return Err(NavPvtError::WrongMessage { class: frame.class, id: frame.id });
        }
        let p = frame.payload.as_slice();
        if p.len() != LEN {
            return Err(NavPvtError::Length(p.len()));
        }
        let mm = |at| f64::from(i32_at(p, at)) / 1e3;
        let umm = |at| f64::from(u32_at(p, at)) / 1e3;
        Ok(NavPvt {
            itow_ms: u32_at(p, 0),
            utc_valid: p[11] & 0b11 == 0b11,
            utc: [
                u16::from_le_bytes([p[4], p[5]]),
                u16::from(p[6]),
                u16::from(p[7]),
                u16::from(p[8]),
                u16::from(p[9]),
                u16::from(p[10]),
            ],
            fix_type_raw: p[20],
            gnss_fix_ok: p[21] & 0x01 != 0,
            diff_soln: p[21] & 0x02 != 0,
            carr_soln: (p[21] >> 6) & 0b11,
            num_sv: p[23],
            lon_deg: deg_from_e7(f64::from(i32_at(p, 24))),
            lat_deg: deg_from_e7(f64::from(i32_at(p, 28))),
            height_ellipsoid_m: mm(32),
            height_msl_m: mm(36),
            h_acc_m: umm(40),
            v_acc_m: umm(44),
            vel_ned_m_s: [mm(48), mm(52), mm(56)],
            s_acc_m_s: umm(68),
            pdop: f64::from(u16::from_le_bytes([p[76], p[77]])) / 100.0,
        })
    }

    /// The fix quality: only 2-D, 3-D and GNSS + dead-reckoning solutions flagged gnssFixOK
    /// count (u-blox advises ignoring the rest); differential and RTK solutions are raised
    /// from `diffSoln` and `carrSoln`.
    pub fn fix_type(&self) -> GpsFixType {
        if !self.gnss_fix_ok {
            return GpsFixType::NoFix;
        }
        match (self.fix_type_raw, self.carr_soln, self.diff_soln) {
            (2, _, _) => GpsFixType::Fix2d,
            (3 | 4, 2, _) => GpsFixType::RtkFixed,
            (3 | 4, 1, _) => GpsFixType::RtkFloat,
            (3 | 4, _, true) => GpsFixType::Dgps,
            (3 | 4, _, false) => GpsFixType::Fix3d,
            _ => GpsFixType::NoFix,
        }
    }

    /// The solution as a [`GpsFix`] valid at `time` (the graph time of this epoch, e.g. from
    /// [`ValidityClock`](crate::ubx::ValidityClock)).
    pub fn to_gps_fix(&self, time: Time) -> GpsFix {
        GpsFix {
            time,
            fix_type: self.fix_type(),
            satellites: self.num_sv,
            lat_deg: self.lat_deg,
            lon_deg: self.lon_deg,
            alt_msl_m: self.height_msl_m,
            vel_ned_m_s: self.vel_ned_m_s,
            h_acc_m: self.h_acc_m,
            v_acc_m: self.v_acc_m,
            s_acc_m_s: self.s_acc_m_s,
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::ubx::parser::UbxParser;

    /// A NAV-PVT recorded from a u-blox M10 in Trondheim on 2022-02-21 14:01:25 UTC, as
    /// published in the test suite of a public Zephyr GNSS driver (ztest `test_receive_gnss_solution`,
    /// `nav_pvt_01`, which asserts lat 633743868 and lon 103412316 in 1e-7 degrees).
    pub(crate) const RECORDED_NAV_PVT: [u8; 100] = [
        0xB5, 0x62, 0x01, 0x07, 0x5C, 0x00, 0x58, 0xF9, 0x28, 0x08, 0xE6, 0x07, 0x02, 0x15, 0x0E, 0x01, 0x19,
        0x37, 0x1F, 0x00, 0x00, 0x00, 0xCA, 0x3A, 0xFA, 0xFF, 0x03, 0x01, 0xFA, 0x0E, 0x5C, 0xF2, 0x29, 0x06,
        0xFC, 0x29, 0xC6, 0x25, 0x38, 0x0E, 0x03, 0x00, 0xBA, 0x71, 0x02, 0x00, 0xEC, 0x0A, 0x00, 0x00, 0x6B,
        0x15, 0x00, 0x00, 0xF1, 0xFF, 0xFF, 0xFF, 0xFC, 0xFF, 0xFF, 0xFF, 0x0D, 0x00, 0x00, 0x00, 0x0F, 0x00,
        0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x97, 0x01, 0x00, 0x00, 0x72, 0xD0, 0xE0, 0x00, 0xAD, 0x00, 0x00,
        0x00, 0xD2, 0x7A, 0x5B, 0x21, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1B, 0x8A,
    ];

    fn recorded() -> NavPvt {
        let mut parser = UbxParser::new();
        parser.push(&RECORDED_NAV_PVT);
        NavPvt::decode(&parser.next_frame().expect("checksum valid")).expect("NAV-PVT")
    }

    #[test]
    fn decodes_a_recorded_solution() {
        let pvt = recorded();
        assert_eq!(pvt.itow_ms, 136_903_000);
        assert!(pvt.utc_valid);
        assert_eq!(pvt.utc, [2022, 2, 21, 14, 1, 25]);
        assert_eq!(pvt.num_sv, 14);
        assert!((pvt.lat_deg - 63.374_386_8).abs() < 1e-9);
        assert!((pvt.lon_deg - 10.341_231_6).abs() < 1e-9);
        assert!((pvt.height_msl_m - 160.186).abs() < 1e-9);
        assert!((pvt.height_ellipsoid_m - 200.248).abs() < 1e-9);
        assert!((pvt.pdop - 1.73).abs() < 1e-9);
        let fix = pvt.to_gps_fix(Time::from_micros(42));
        assert_eq!(fix.fix_type, GpsFixType::Fix3d);
        assert_eq!(fix.time, Time::from_micros(42));
        assert_eq!(fix.vel_ned_m_s, [-0.015, -0.004, 0.013]);
        assert!((fix.h_acc_m - 2.796).abs() < 1e-9);
        assert!((fix.v_acc_m - 5.483).abs() < 1e-9);
        assert!((fix.s_acc_m_s - 0.407).abs() < 1e-9);
    }

    #[test]
    fn fix_quality_follows_the_flags() {
        let mut pvt = recorded();
        pvt.gnss_fix_ok = false;
        assert_eq!(pvt.fix_type(), GpsFixType::NoFix);
        pvt.gnss_fix_ok = true;
        pvt.carr_soln = 2;
        assert_eq!(pvt.fix_type(), GpsFixType::RtkFixed);
        pvt.carr_soln = 0;
        pvt.diff_soln = true;
        assert_eq!(pvt.fix_type(), GpsFixType::Dgps);
        pvt.fix_type_raw = 5;
        assert_eq!(pvt.fix_type(), GpsFixType::NoFix);
    }

    #[test]
    fn other_messages_and_short_payloads_are_errors() {
        let ack = UbxFrame { class: 0x05, id: 0x01, payload: vec![6, 1] };
        assert_eq!(NavPvt::decode(&ack), Err(NavPvtError::WrongMessage { class: 5, id: 1 }));
        let short = UbxFrame { class: CLASS, id: ID, payload: vec![0; 84] };
        assert_eq!(NavPvt::decode(&short), Err(NavPvtError::Length(84)));
    }
}
