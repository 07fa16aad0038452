//! The GPS driver's pure core: serial bytes in, [`GpsFix`]es out.
//!
//! The same bytes go to a UBX parser and an NMEA line splitter, because a receiver may send
//! both (a u-blox before it has been configured talks NMEA at 9600 baud) and a non-u-blox
//! receiver sends only NMEA. NAV-PVT is preferred: while NAV-PVT solutions arrive, NMEA fixes
//! are decoded but not published, so the estimator never sees two fixes of one epoch; once
//! NAV-PVT has been silent for [`NMEA_FALLBACK_AFTER`], NMEA fixes are published again.
//! Anything unusable — a frame with a bad checksum, a truncated frame, line noise, a sentence
//! that does not decode — is skipped and counted, never fatal.

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::messages::GpsFix;

use crate::nmea::{NmeaError, NmeaFixAssembler, NmeaFixOptions, NmeaMessage, NmeaReader, Sentence};
use crate::ubx::{NavPvt, UbxParser, ValidityClock};

/// NAV-PVT silence after which NMEA fixes are published (five epochs at 5 Hz).
pub const NMEA_FALLBACK_AFTER: Duration = Duration::from_secs(1);

/// UBX-ACK class and the ids of ACK-NAK and ACK-ACK.
const CLASS_ACK: u8 = 0x05;
const ID_NAK: u8 = 0x00;
const ID_ACK: u8 = 0x01;

/// What the decoder has seen since it started.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GpsStats {
    /// Fixes returned (from either protocol).
    pub fixes: u64,
    /// NAV-PVT solutions decoded.
    pub nav_pvt: u64,
    /// NMEA fixes assembled, published or not.
    pub nmea_fixes: u64,
    /// UBX frames rejected for their checksum or an impossible length, and frames with the
    /// NAV-PVT id but the wrong length.
    pub ubx_errors: u64,
    /// NMEA sentences rejected for their checksum, fields or length.
    pub nmea_errors: u64,
    /// Configuration messages the receiver acknowledged (ACK-ACK).
    pub acks: u64,
    /// Configuration messages the receiver refused (ACK-NAK).
    pub naks: u64,
}

impl GpsStats {
    /// Bad input of either protocol.
    pub fn errors(&self) -> u64 {
        self.ubx_errors + self.nmea_errors
    }
}

/// UBX and NMEA decoding of one receiver's byte stream.
#[derive(Clone, Debug)]
pub struct GpsDecoder {
    ubx: UbxParser,
    validity: ValidityClock,
    nmea: NmeaReader,
    assembler: NmeaFixAssembler,
    last_nav_pvt: Option<Time>,
    stats: GpsStats,
}

impl GpsDecoder {
    /// A decoder for a receiver whose least-delayed NAV-PVT arrives `ubx_latency` after its
    /// epoch, filling NMEA-only quantities from `nmea`.
    pub fn new(ubx_latency: Duration, nmea: NmeaFixOptions) -> GpsDecoder {
        GpsDecoder {
            ubx: UbxParser::new(),
            validity: ValidityClock::new(ubx_latency),
            nmea: NmeaReader::new(),
            assembler: NmeaFixAssembler::new(nmea),
            last_nav_pvt: None,
            stats: GpsStats::default(),
        }
    }

    /// Counters so far.
    pub fn stats(&self) -> GpsStats {
        let parser = self.ubx.stats();
        GpsStats {
            ubx_errors: self.stats.ubx_errors + parser.checksum_errors + parser.oversize,
            nmea_errors: self.stats.nmea_errors + self.nmea.overlong,
            ..self.stats
        }
    }

    /// Takes bytes that arrived at `arrival` and returns the fixes they complete, each stamped
    /// with its time of validity.
    pub fn push(&mut self, bytes: &[u8], arrival: Time) -> Vec<GpsFix> {
        let mut fixes = Vec::new();
        self.ubx.push(bytes);
        while let Some(frame) = self.ubx.next_frame() {
            match (frame.class, frame.id) {
                (CLASS_ACK, ID_ACK) => self.stats.acks += 1,
                (CLASS_ACK, ID_NAK) => {
                    self.stats.naks += 1;
                    tracing::warn!(refused = ?frame.payload, "the GPS receiver refused a configuration message");
                }
                (crate::ubx::nav_pvt::CLASS, crate::ubx::nav_pvt::ID) => match NavPvt::decode(&frame) {
                    Ok(pvt) => {
                        self.stats.nav_pvt += 1;
                        self.last_nav_pvt = Some(arrival);
                        let time = self.validity.time_of_validity(pvt.itow_ms, arrival);
                        fixes.push(pvt.to_gps_fix(time));
                    }
                    Err(_) => self.stats.ubx_errors += 1,
                },
                _ => {}
            }
        }
        let mut lines = Vec::new();
        self.nmea.push(bytes, |line| lines.push(line.to_owned()));
        for line in lines {
            let message = Sentence::parse(&line).and_then(|s| NmeaMessage::decode(&s));
            match message {
                Ok(message) => {
                    if let Some(fix) = self.assembler.push(message, arrival) {
                        self.stats.nmea_fixes += 1;
                        if self.nmea_in_charge(arrival) {
                            fixes.push(fix);
                        }
                    }
                }
                // Binary UBX bytes can contain a `$` and a line feed; without a `*hh` checksum
                // that is not a sentence, and the UBX parser accounts for those bytes.
                Err(NmeaError::Framing(_)) => {}
                Err(_) => self.stats.nmea_errors += 1,
            }
        }
        self.stats.fixes += fixes.len() as u64;
        fixes
    }

    /// Whether NMEA fixes are published: no NAV-PVT yet, or none for a while.
    fn nmea_in_charge(&self, now: Time) -> bool {
        self.last_nav_pvt.is_none_or(|last| now.saturating_since(last) >= NMEA_FALLBACK_AFTER)
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::messages::GpsFixType;

    use super::*;
    use crate::ubx::encode;
    use crate::ubx::nav_pvt::tests::RECORDED_NAV_PVT;

    /// The recorded NAV-PVT with its time of week replaced (and the checksum recomputed).
    pub(crate) fn nav_pvt_at(itow_ms: u32) -> Vec<u8> {
        let mut payload = RECORDED_NAV_PVT[6..98].to_vec();
        payload[0..4].copy_from_slice(&itow_ms.to_le_bytes());
        encode(0x01, 0x07, &payload)
    }

    /// GGA and RMC of one epoch, the examples of the NMEA 0183 reference widely reprinted
    /// (gpsinformation.org "NMEA data"): 48°07.038' N, 11°31.000' E, 545.4 m, 22.4 kn at 84.4°.
    const GGA: &[u8] = b"$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47\r\n";
    const RMC: &[u8] = b"$GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W*6A\r\n";

    fn decoder() -> GpsDecoder {
        GpsDecoder::new(Duration::from_millis(50), NmeaFixOptions::default())
    }

    #[test]
    fn nav_pvt_becomes_a_fix_stamped_before_its_arrival() {
        let mut d = decoder();
        let fixes = d.push(&nav_pvt_at(136_903_000), Time::from_micros(10_000_000));
        assert_eq!(fixes.len(), 1);
        assert_eq!(fixes[0].time, Time::from_micros(9_950_000));
        assert_eq!((fixes[0].fix_type, fixes[0].satellites), (GpsFixType::Fix3d, 14));
        assert!((fixes[0].lat_deg - 63.374_386_8).abs() < 1e-9);
        assert_eq!(d.stats().nav_pvt, 1);
    }

    #[test]
    fn garbage_truncated_and_corrupt_frames_are_counted_and_skipped() {
        let mut d = decoder();
        let mut corrupt = nav_pvt_at(1_000);
        corrupt[50] ^= 0x40;
        let truncated = nav_pvt_at(1_200)[..60].to_vec();
        let stream = [
            vec![0x00, 0xFF, 0x13, 0xB5, 0x37],
            corrupt,
            truncated,
            b"$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*48\r\n".to_vec(),
            nav_pvt_at(1_400),
        ]
        .concat();
        let fixes: Vec<GpsFix> =
            stream.chunks(13).flat_map(|c| d.push(c, Time::from_micros(5_000_000))).collect();
        assert_eq!(fixes.len(), 1);
        let stats = d.stats();
        assert_eq!(stats.nav_pvt, 1);
        assert!(stats.ubx_errors >= 2, "{stats:?}");
        assert_eq!(stats.nmea_errors, 1, "{stats:?}");
    }

    #[test]
    fn nmea_is_the_fallback_while_nav_pvt_is_silent() {
        let mut d = decoder();
        let nmea = [RMC, GGA].concat();
        assert_eq!(d.push(&nmea, Time::from_micros(1_000_000)).len(), 1, "NMEA-only receiver");
        assert_eq!(d.push(&nav_pvt_at(5_000), Time::from_micros(1_100_000)).len(), 1);
        assert!(d.push(&nmea, Time::from_micros(1_200_000)).is_empty(), "NAV-PVT in charge");
        let fixes = d.push(&nmea, Time::from_micros(2_200_000));
        assert_eq!(fixes.len(), 1, "NAV-PVT silent for 1.1 s");
        assert!((fixes[0].alt_msl_m - 545.4).abs() < 1e-9);
        assert_eq!(d.stats().nmea_fixes, 3);
    }

    #[test]
    fn acknowledgements_are_counted() {
        let mut d = decoder();
        d.push(&encode(0x05, 0x01, &[0x06, 0x08]), Time::ZERO);
        d.push(&encode(0x05, 0x00, &[0x06, 0x24]), Time::ZERO);
        assert_eq!((d.stats().acks, d.stats().naks), (1, 1));
    }
}
