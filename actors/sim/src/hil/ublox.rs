//! A u-blox M8 receiver's UART protocol (u-blox 8 / M8 Receiver Description, UBX-13003221):
//! it powers up at 9600 baud, takes UBX-CFG messages (each answered by UBX-ACK-ACK, or ACK-NAK
//! when it cannot apply them), moves its UART to the rate a CFG-PRT names once it has
//! acknowledged it, and sends UBX-NAV-PVT for each solution once CFG-MSG has enabled it.
//!
//! The solutions are the simulator's own GPS model (its rate, lag, noise and faults): the
//! receiver only encodes each released [`GpsFix`] with the iTOW of its epoch. Bytes that arrive
//! while the host's line rate differs from the receiver's are garbage to it, as on a real UART:
//! they are counted and dropped, and nothing is sent until the rates agree.

use kestrel_proto::Time;
use kestrel_proto::messages::{GpsFix, GpsFixType};

const SYNC: [u8; 2] = [0xB5, 0x62];
const CLASS_NAV: u8 = 0x01;
const ID_NAV_PVT: u8 = 0x07;
const CLASS_ACK: u8 = 0x05;
const ID_ACK_NAK: u8 = 0x00;
const ID_ACK_ACK: u8 = 0x01;
const CLASS_CFG: u8 = 0x06;
const ID_CFG_PRT: u8 = 0x00;
const ID_CFG_MSG: u8 = 0x01;
const ID_CFG_RATE: u8 = 0x08;
const ID_CFG_NAV5: u8 = 0x24;
/// The UART the flight computer is wired to on M8N modules.
const UART1: u8 = 1;
/// `outProtoMask` bit for UBX.
const PROTO_UBX: u16 = 0x0001;
/// Largest payload a configuration message carries here; longer frames are noise.
const MAX_PAYLOAD: usize = 512;
/// Factory line rate (bit/s).
pub const POWER_UP_BAUD: u32 = 9600;
/// GPS time of week at the graph clock's origin (ms): an arbitrary Wednesday noon, far from the
/// week's rollover for any flight.
const ITOW_AT_ORIGIN_MS: u32 = 302_400_000;
/// UTC date the solutions carry (the simulated world has no calendar).
const UTC_DATE: [u16; 3] = [2026, 1, 7];

/// What the receiver has been told and has seen.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ReceiverState {
    /// The UART's rate (bit/s).
    pub baud: u32,
    /// UBX out on UART1 (CFG-PRT `outProtoMask`); on at power-up (the M8's default is UBX+NMEA).
    pub ubx_out: bool,
    /// NAV-PVT solutions per navigation solution (CFG-MSG on UART1); 0 = off.
    pub nav_pvt_rate: u8,
    /// Measurement period (CFG-RATE, ms).
    pub meas_period_ms: u16,
    /// Dynamic platform model (CFG-NAV5 `dynModel`).
    pub dynamic_model: u8,
    /// CFG messages acknowledged, and refused.
    pub acked: u32,
    pub naked: u32,
    /// Bytes dropped because they arrived at another line rate, and frames with a bad checksum.
    pub garbled_bytes: u64,
    pub bad_checksums: u32,
}

/// The receiver.
#[derive(Clone, Debug)]
pub struct UbloxReceiver {
    state: ReceiverState,
    rx: Vec<u8>,
}

impl Default for UbloxReceiver {
    fn default() -> UbloxReceiver {
        UbloxReceiver::new()
    }
}

impl UbloxReceiver {
    /// A receiver as it powers up: 9600 baud, 1 Hz, portable model, NAV-PVT off.
    pub fn new() -> UbloxReceiver {
        UbloxReceiver {
            state: ReceiverState {
                baud: POWER_UP_BAUD,
                ubx_out: true,
                nav_pvt_rate: 0,
                meas_period_ms: 1000,
                dynamic_model: 0,
                acked: 0,
                naked: 0,
                garbled_bytes: 0,
                bad_checksums: 0,
            },
            rx: Vec::new(),
        }
    }

    /// What it has been told.
    pub fn state(&self) -> &ReceiverState {
        &self.state
    }

    /// Whether a host on a line at `line_baud` understands what the receiver sends.
    pub fn understood_at(&self, line_baud: u32) -> bool {
        line_baud == self.state.baud
    }

    /// Bytes from the host on a line at `line_baud`; returns the bytes the receiver sends back
    /// (acknowledgements, at the rate in force before a CFG-PRT takes effect).
    pub fn receive(&mut self, bytes: &[u8], line_baud: u32) -> Vec<u8> {
        if !self.understood_at(line_baud) {
            self.state.garbled_bytes += bytes.len() as u64;
            self.rx.clear();
            return Vec::new();
        }
        self.rx.extend_from_slice(bytes);
        let mut out = Vec::new();
        while let Some((class, id, payload)) = self.next_frame() {
            if class == CLASS_CFG {
                self.configure(id, &payload, &mut out);
            }
        }
        out
    }

    /// The NAV-PVT frame for `fix` (valid at `fix.time`), if the host enabled it.
    pub fn solution(&self, fix: &GpsFix) -> Option<Vec<u8>> {
        (self.state.nav_pvt_rate > 0 && self.state.ubx_out)
            .then(|| frame(CLASS_NAV, ID_NAV_PVT, &nav_pvt(fix)))
    }

    /// Takes the next whole frame out of the receive buffer, skipping noise.
    fn next_frame(&mut self) -> Option<(u8, u8, Vec<u8>)> {
        loop {
            let start = self.rx.windows(2).position(|w| w == SYNC)?;
            self.rx.drain(..start);
            if self.rx.len() < 6 {
                return None;
            }
            let len = usize::from(u16::from_le_bytes([self.rx[4], self.rx[5]]));
            if len > MAX_PAYLOAD {
                self.rx.drain(..2);
                continue;
            }
            if self.rx.len() < 8 + len {
                return None;
            }
            let body = &self.rx[2..6 + len];
            let ok = checksum(body) == (self.rx[6 + len], self.rx[7 + len]);
            let parsed = (self.rx[2], self.rx[3], self.rx[6..6 + len].to_vec());
            if ok {
                self.rx.drain(..8 + len);
                return Some(parsed);
            }
            self.state.bad_checksums += 1;
            self.rx.drain(..2);
        }
    }

    fn configure(&mut self, id: u8, p: &[u8], out: &mut Vec<u8>) {
        let applied = match (id, p.len()) {
            (ID_CFG_PRT, 20) if p[0] == UART1 => {
                let baud = u32::from_le_bytes([p[8], p[9], p[10], p[11]]);
                let out_proto = u16::from_le_bytes([p[14], p[15]]);
                // The acknowledgement still goes out at the old rate; then the UART switches.
                out.extend(frame(CLASS_ACK, ID_ACK_ACK, &[CLASS_CFG, id]));
                self.state.acked += 1;
                self.state.baud = baud;
                self.state.ubx_out = out_proto & PROTO_UBX != 0;
                return;
            }
            (ID_CFG_MSG, 3) if (p[0], p[1]) == (CLASS_NAV, ID_NAV_PVT) => {
                self.state.nav_pvt_rate = p[2];
                true
            }
            (ID_CFG_MSG, 8) if (p[0], p[1]) == (CLASS_NAV, ID_NAV_PVT) => {
                self.state.nav_pvt_rate = p[2 + usize::from(UART1)];
                true
            }
            (ID_CFG_MSG, 3 | 8) => true,
            (ID_CFG_RATE, 6) => {
                let period = u16::from_le_bytes([p[0], p[1]]);
                // u-blox M8: 25 ms (40 Hz) and up.
                let ok = period >= 25;
                if ok {
                    self.state.meas_period_ms = period;
                }
                ok
            }
            (ID_CFG_NAV5, 36) => {
                let mask = u16::from_le_bytes([p[0], p[1]]);
                if mask & 0x0001 != 0 {
                    self.state.dynamic_model = p[2];
                }
                true
            }
            _ => false,
        };
        if applied {
            self.state.acked += 1;
            out.extend(frame(CLASS_ACK, ID_ACK_ACK, &[CLASS_CFG, id]));
        } else {
            self.state.naked += 1;
            out.extend(frame(CLASS_ACK, ID_ACK_NAK, &[CLASS_CFG, id]));
        }
    }
}

/// The 8-bit Fletcher checksum over class, id, length and payload (§32.4).
fn checksum(bytes: &[u8]) -> (u8, u8) {
    bytes.iter().fold((0u8, 0u8), |(a, b), &x| {
        let a = a.wrapping_add(x);
        (a, b.wrapping_add(a))
    })
}

/// A whole UBX frame.
fn frame(class: u8, id: u8, payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(8 + payload.len());
    out.extend_from_slice(&SYNC);
    out.extend_from_slice(&[class, id]);
    out.extend_from_slice(&(payload.len() as u16).to_le_bytes());
    out.extend_from_slice(payload);
    let (a, b) = checksum(&out[2..]);
    out.extend_from_slice(&[a, b]);
    out
}

/// The epoch's GPS time of week (ms) for a solution valid at graph time `time`.
pub fn itow_ms(time: Time) -> u32 {
    ITOW_AT_ORIGIN_MS.wrapping_add((time.as_micros() / 1000) as u32) % 604_800_000
}

/// The 92-byte NAV-PVT payload (§32.17.15) of `fix`. The world has no geoid: the ellipsoid
/// height is the height above mean sea level.
fn nav_pvt(fix: &GpsFix) -> [u8; 92] {
    let mut p = [0u8; 92];
    let itow = itow_ms(fix.time);
    let put_u32 = |p: &mut [u8; 92], at: usize, v: u32| p[at..at + 4].copy_from_slice(&v.to_le_bytes());
    let put_i32 = |p: &mut [u8; 92], at: usize, v: i32| p[at..at + 4].copy_from_slice(&v.to_le_bytes());
    let mm = |m: f64| (m * 1e3).round().clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32;
    let umm = |m: f64| (m * 1e3).round().clamp(0.0, f64::from(u32::MAX)) as u32;
    put_u32(&mut p, 0, itow);
    p[4..6].copy_from_slice(&UTC_DATE[0].to_le_bytes());
    p[6] = UTC_DATE[1] as u8;
    p[7] = UTC_DATE[2] as u8;
    let seconds_of_day = (itow / 1000) % 86_400;
    p[8] = (seconds_of_day / 3600) as u8;
    p[9] = (seconds_of_day / 60 % 60) as u8;
    p[10] = (seconds_of_day % 60) as u8;
    // validDate, validTime.
    p[11] = 0b0000_0011;
    let (fix_type, flags) = match fix.fix_type {
        GpsFixType::NoFix => (0u8, 0u8),
        GpsFixType::Fix2d => (2, 0x01),
        GpsFixType::Fix3d => (3, 0x01),
        GpsFixType::Dgps => (3, 0x03),
        GpsFixType::RtkFloat => (3, 0x03 | 0x40),
        GpsFixType::RtkFixed => (3, 0x03 | 0x80),
    };
    p[20] = fix_type;
    p[21] = flags;
    p[23] = fix.satellites;
    put_i32(&mut p, 24, (fix.lon_deg * 1e7).round() as i32);
    put_i32(&mut p, 28, (fix.lat_deg * 1e7).round() as i32);
    put_i32(&mut p, 32, mm(fix.alt_msl_m));
    put_i32(&mut p, 36, mm(fix.alt_msl_m));
    put_u32(&mut p, 40, umm(fix.h_acc_m));
    put_u32(&mut p, 44, umm(fix.v_acc_m));
    let [n, e, d] = fix.vel_ned_m_s;
    put_i32(&mut p, 48, mm(n));
    put_i32(&mut p, 52, mm(e));
    put_i32(&mut p, 56, mm(d));
    put_i32(&mut p, 60, mm(n.hypot(e)));
    put_i32(&mut p, 64, (e.atan2(n).to_degrees().rem_euclid(360.0) * 1e5).round() as i32);
    put_u32(&mut p, 68, umm(fix.s_acc_m_s));
    // headAcc 180 deg: no heading of motion claimed; pDOP from the horizontal accuracy at a
    // typical 2.5 m user range error.
    put_u32(&mut p, 72, 18_000_000);
    let pdop = (fix.h_acc_m / 2.5 * 100.0).round().clamp(0.0, 9999.0) as u16;
    p[76..78].copy_from_slice(&pdop.to_le_bytes());
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg(id: u8, payload: &[u8]) -> Vec<u8> {
        frame(CLASS_CFG, id, payload)
    }

    fn prt(baud: u32) -> Vec<u8> {
        let mut p = [0u8; 20];
        p[0] = UART1;
        p[4..8].copy_from_slice(&0x08D0u32.to_le_bytes());
        p[8..12].copy_from_slice(&baud.to_le_bytes());
        p[12..14].copy_from_slice(&3u16.to_le_bytes());
        p[14..16].copy_from_slice(&PROTO_UBX.to_le_bytes());
        cfg(ID_CFG_PRT, &p)
    }

    #[test]
    fn switches_baud_after_acknowledging_at_the_old_rate() {
        let mut rx = UbloxReceiver::new();
        let ack = rx.receive(&prt(115_200), 9600);
        assert_eq!(ack, frame(CLASS_ACK, ID_ACK_ACK, &[CLASS_CFG, ID_CFG_PRT]));
        assert_eq!(rx.state().baud, 115_200);
        // Still at 9600 on the host side: garbage to the receiver.
        assert!(rx.receive(&cfg(ID_CFG_RATE, &[200, 0, 1, 0, 1, 0]), 9600).is_empty());
        assert!(rx.state().garbled_bytes > 0);
        let ack = rx.receive(&cfg(ID_CFG_RATE, &[200, 0, 1, 0, 1, 0]), 115_200);
        assert_eq!(ack, frame(CLASS_ACK, ID_ACK_ACK, &[CLASS_CFG, ID_CFG_RATE]));
        assert_eq!(rx.state().meas_period_ms, 200);
    }

    #[test]
    fn nav_pvt_only_once_enabled_and_refusals_are_naked() {
        let mut rx = UbloxReceiver::new();
        let fix = GpsFix {
            time: Time::from_micros(1_234_567),
            fix_type: GpsFixType::Fix3d,
            satellites: 12,
            lat_deg: 6.7971,
            lon_deg: 79.9017,
            alt_msl_m: 20.0,
            vel_ned_m_s: [1.0, -2.0, 0.5],
            h_acc_m: 0.8,
            v_acc_m: 1.2,
            s_acc_m_s: 0.2,
        };
        assert!(rx.solution(&fix).is_none());
        rx.receive(&cfg(ID_CFG_MSG, &[CLASS_NAV, ID_NAV_PVT, 1]), 9600);
        let f = rx.solution(&fix).expect("enabled");
        assert_eq!((f.len(), &f[..4]), (100, &[0xB5, 0x62, 0x01, 0x07][..]));
        assert_eq!(checksum(&f[2..98]), (f[98], f[99]));
        let p = &f[6..98];
        assert_eq!(u32::from_le_bytes([p[0], p[1], p[2], p[3]]), ITOW_AT_ORIGIN_MS + 1234);
        assert_eq!(i32::from_le_bytes([p[28], p[29], p[30], p[31]]), 67_971_000);
        assert_eq!(i32::from_le_bytes([p[52], p[53], p[54], p[55]]), -2000);
        assert_eq!((p[20], p[21], p[23]), (3, 0x01, 12));
        let nak = rx.receive(&cfg(ID_CFG_RATE, &[10, 0, 1, 0, 1, 0]), 9600);
        assert_eq!(nak, frame(CLASS_ACK, ID_ACK_NAK, &[CLASS_CFG, ID_CFG_RATE]));
        assert_eq!((rx.state().acked, rx.state().naked), (1, 1));
    }

    #[test]
    fn noise_and_bad_checksums_are_skipped() {
        let mut rx = UbloxReceiver::new();
        let mut bytes = b"$GPGGA,noise*00\r\n".to_vec();
        let mut bad = cfg(ID_CFG_MSG, &[CLASS_NAV, ID_NAV_PVT, 1]);
        *bad.last_mut().expect("frame") ^= 1;
        bytes.extend(bad);
        bytes.extend(cfg(ID_CFG_MSG, &[CLASS_NAV, ID_NAV_PVT, 1]));
        let acks = rx.receive(&bytes, 9600);
        assert_eq!(acks, frame(CLASS_ACK, ID_ACK_ACK, &[CLASS_CFG, ID_CFG_MSG]));
        assert_eq!((rx.state().bad_checksums, rx.state().nav_pvt_rate), (1, 1));
    }
}
