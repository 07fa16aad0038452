//! The three sentences a position fix needs (NMEA 0183 v4.10 §6.3): GGA (position, fix
//! quality, satellites, HDOP, altitude), RMC (position, speed and course over ground) and VTG
//! (speed and course over ground).

use crate::nmea::sentence::{NmeaError, Sentence};

/// One knot (m/s).
pub const KNOT_M_S: f64 = 1852.0 / 3600.0;

/// GGA: global positioning fix data.
#[derive(Clone, Debug, PartialEq)]
pub struct Gga {
    /// UTC time of the fix, seconds since midnight.
    pub utc_s: f64,
    /// Latitude (degrees, north positive); `None` without a fix.
    pub lat_deg: Option<f64>,
    /// Longitude (degrees, east positive); `None` without a fix.
    pub lon_deg: Option<f64>,
    /// Quality: 0 invalid, 1 GPS, 2 DGPS, 4 RTK fixed, 5 RTK float, 6 dead reckoning.
    pub quality: u8,
    pub satellites: u8,
    /// Horizontal dilution of precision; `None` when the receiver leaves it empty.
    pub hdop: Option<f64>,
    /// Antenna altitude above mean sea level (m); `None` for a 2-D fix.
    pub alt_msl_m: Option<f64>,
}

/// RMC: recommended minimum data. Only the velocity part is used.
#[derive(Clone, Debug, PartialEq)]
pub struct Rmc {
    /// UTC time of the fix, seconds since midnight.
    pub utc_s: f64,
    /// Status `A` (valid); `V` sentences carry no usable data.
    pub valid: bool,
    /// Speed over ground (m/s).
    pub speed_m_s: Option<f64>,
    /// Course over ground, degrees clockwise from true north.
    pub course_deg: Option<f64>,
}

/// VTG: course over ground and ground speed.
#[derive(Clone, Debug, PartialEq)]
pub struct Vtg {
    /// Course over ground, degrees clockwise from true north.
    pub course_deg: Option<f64>,
    /// Speed over ground (m/s), from the km/h field (the knots field if that is empty).
    pub speed_m_s: Option<f64>,
}

/// A decoded sentence this crate uses.
#[derive(Clone, Debug, PartialEq)]
pub enum NmeaMessage {
    Gga(Gga),
    Rmc(Rmc),
    Vtg(Vtg),
    /// Any other valid sentence (GSA, GSV, TXT, ...), by address.
    Other(String),
}

impl NmeaMessage {
    /// Decodes a checksum-valid sentence.
    pub fn decode(s: &Sentence) -> Result<NmeaMessage, NmeaError> {
        match s.kind() {
            "GGA" => Gga::decode(s).map(NmeaMessage::Gga),
            "RMC" => Rmc::decode(s).map(NmeaMessage::Rmc),
            "VTG" => Vtg::decode(s).map(NmeaMessage::Vtg),
            _ => Ok(NmeaMessage::Other(s.address.clone())),
        }
    }
}

/// Field access with errors naming the sentence and field.
struct Fields<'a> {
    kind: &'static str,
    fields: &'a [String],
}

impl<'a> Fields<'a> {
    fn new(kind: &'static str, s: &'a Sentence, expected: usize) -> Result<Fields<'a>, NmeaError> {
        if s.fields.len() < expected {
            return Err(NmeaError::TooShort { kind, got: s.fields.len(), expected });
        }
        Ok(Fields { kind, fields: &s.fields })
    }

    fn bad(&self, index: usize) -> NmeaError {
        NmeaError::Field { kind: self.kind, index, field: self.fields[index].clone() }
    }

    fn str(&self, index: usize) -> &str {
        &self.fields[index]
    }

    /// A number, `None` when the field is empty.
    fn number(&self, index: usize) -> Result<Option<f64>, NmeaError> {
        match self.str(index) {
            "" => Ok(None),
            f => f.parse::<f64>().ok().filter(|v| v.is_finite()).map(Some).ok_or_else(|| self.bad(index)),
        }
    }

    /// `hhmmss.ss` as seconds since midnight.
    fn utc(&self, index: usize) -> Result<f64, NmeaError> {
        let f = self.str(index);
        if !f.bytes().all(|b| b.is_ascii_digit() || b == b'.') {
            return Err(self.bad(index));
        }
        let part = |r: std::ops::Range<usize>| f.get(r).and_then(|p| p.parse::<f64>().ok());
        match (part(0..2), part(2..4), part(4..f.len())) {
            (Some(h), Some(m), Some(s)) if h < 24.0 && m < 60.0 && s < 61.0 => Ok(h * 3600.0 + m * 60.0 + s),
            _ => Err(self.bad(index)),
        }
    }

    /// `(d)ddmm.mmmm` and its hemisphere letter as signed degrees; `None` when empty.
    fn angle(&self, index: usize, positive: &str, negative: &str) -> Result<Option<f64>, NmeaError> {
        let Some(value) = self.number(index)? else { return Ok(None) };
        let degrees = (value / 100.0).trunc();
        let minutes = value - degrees * 100.0;
        if value < 0.0 || minutes >= 60.0 {
            return Err(self.bad(index));
        }
        let magnitude = degrees + minutes / 60.0;
        match self.str(index + 1) {
            h if h == positive => Ok(Some(magnitude)),
            h if h == negative => Ok(Some(-magnitude)),
            _ => Err(self.bad(index + 1)),
        }
    }

    fn integer(&self, index: usize) -> Result<u8, NmeaError> {
        match self.str(index) {
            "" => Ok(0),
            f => f.parse().map_err(|_| self.bad(index)),
        }
    }
}

impl Gga {
    /// Decodes `GxGGA`.
    pub fn decode(s: &Sentence) -> Result<Gga, NmeaError> {
        let f = Fields::new("GGA", s, 9)?;
        Ok(Gga {
            utc_s: f.utc(0)?,
            lat_deg: f.angle(1, "N", "S")?,
            lon_deg: f.angle(3, "E", "W")?,
            quality: f.integer(5)?,
            satellites: f.integer(6)?,
            hdop: f.number(7)?,
            alt_msl_m: f.number(8)?,
        })
    }
}

impl Rmc {
    /// Decodes `GxRMC`.
    pub fn decode(s: &Sentence) -> Result<Rmc, NmeaError> {
        let f = Fields::new("RMC", s, 8)?;
        Ok(Rmc {
            utc_s: f.utc(0)?,
            valid: f.str(1) == "A",
            speed_m_s: f.number(6)?.map(|knots| knots * KNOT_M_S),
            course_deg: f.number(7)?,
        })
    }
}

impl Vtg {
    /// Decodes `GxVTG`.
    pub fn decode(s: &Sentence) -> Result<Vtg, NmeaError> {
        let f = Fields::new("VTG", s, 8)?;
        let km_h = f.number(6)?.map(|v| v / 3.6);
        let knots = f.number(4)?.map(|v| v * KNOT_M_S);
        Ok(Vtg { course_deg: f.number(0)?, speed_m_s: km_h.or(knots) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decode(line: &str) -> NmeaMessage {
        NmeaMessage::decode(&Sentence::parse(line).expect("valid sentence")).expect("decodes")
    }

    #[test]
    fn the_classic_gga_example() {
        // The GGA example of the NMEA reference guides (e.g. gpsinformation.org, u-blox M8).
        let NmeaMessage::Gga(gga) =
            decode("$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47")
        else {
            panic!("not GGA")
        };
        assert_eq!(gga.utc_s, 12.0 * 3600.0 + 35.0 * 60.0 + 19.0);
        assert!((gga.lat_deg.expect("lat") - (48.0 + 7.038 / 60.0)).abs() < 1e-12);
        assert!((gga.lon_deg.expect("lon") - (11.0 + 31.0 / 60.0)).abs() < 1e-12);
        assert_eq!((gga.quality, gga.satellites, gga.hdop, gga.alt_msl_m), (1, 8, Some(0.9), Some(545.4)));
    }

    #[test]
    fn a_recorded_gngga_and_a_bad_time() {
        let NmeaMessage::Gga(gga) =
            decode("$GNGGA,173002.00,6322.46840,N,01020.45757,E,1,05,7.83,167.0,M,40.1,M,,*45")
        else {
            panic!("not GGA")
        };
        assert!((gga.lat_deg.expect("lat") - 63.374_473_3).abs() < 1e-6);
        assert!((gga.lon_deg.expect("lon") - 10.340_959_5).abs() < 1e-6);
        let s = Sentence {
            address: "GPGGA".into(),
            fields: ["1", "4807.038", "S", "01131.000", "W", "1", "8", "", ""].map(String::from).to_vec(),
        };
        assert!(matches!(Gga::decode(&s), Err(NmeaError::Field { index: 0, .. })));
    }

    #[test]
    fn rmc_and_vtg_speeds() {
        let NmeaMessage::Rmc(rmc) =
            decode("$GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W*6A")
        else {
            panic!("not RMC")
        };
        assert!(rmc.valid);
        assert!((rmc.speed_m_s.expect("speed") - 22.4 * 0.514_444).abs() < 1e-3);
        assert_eq!(rmc.course_deg, Some(84.4));
        let NmeaMessage::Vtg(vtg) = decode("$GPVTG,054.7,T,034.4,M,005.5,N,010.2,K*48") else {
            panic!("not VTG")
        };
        assert_eq!(vtg.course_deg, Some(54.7));
        assert!((vtg.speed_m_s.expect("speed") - 10.2 / 3.6).abs() < 1e-12);
    }

    #[test]
    fn garbage_fields_are_errors_not_panics() {
        let s = Sentence { address: "GPGGA".into(), fields: vec!["12".into()] };
        assert!(matches!(Gga::decode(&s), Err(NmeaError::TooShort { .. })));
        let s = Sentence {
            address: "GPGGA".into(),
            fields: ["123519", "4807.038", "Q", "01131.000", "E", "1", "8", "", ""]
                .map(String::from)
                .to_vec(),
        };
        assert!(matches!(Gga::decode(&s), Err(NmeaError::Field { index: 2, .. })));
    }
}
