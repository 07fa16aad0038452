//! NMEA 0183 sentence framing: `$` talker+type `,` fields `*` two hex digits of the XOR of every
//! character between `$` and `*`, then CR LF (NMEA 0183 v4.10 §5.2.1; 82 characters at most).

/// Longest sentence accepted (characters, `$` to LF); the standard allows 82, some receivers
/// exceed it with extra precision, so allow some slack.
pub const MAX_SENTENCE: usize = 120;

/// Why a sentence was rejected.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum NmeaError {
    #[error("no `$` start or `*hh` checksum in {0:?}")]
    Framing(String),
    #[error("checksum mismatch in {sentence:?}: stated {stated:#04x}, computed {computed:#04x}")]
    Checksum { sentence: String, stated: u8, computed: u8 },
    #[error("{kind} field {index} ({field:?}) is not valid")]
    Field { kind: &'static str, index: usize, field: String },
    #[error("{kind} has {got} fields, expected at least {expected}")]
    TooShort { kind: &'static str, got: usize, expected: usize },
}

/// A checksum-valid sentence split at its commas.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Sentence {
    /// Talker and sentence type, e.g. `GPGGA`, `GNRMC`.
    pub address: String,
    /// The comma-separated fields after the address.
    pub fields: Vec<String>,
}

impl Sentence {
    /// Parses one sentence, with or without its trailing CR LF.
    pub fn parse(line: &str) -> Result<Sentence, NmeaError> {
        let line = line.trim_end_matches(['\r', '\n']);
        let framing = || NmeaError::Framing(line.chars().take(MAX_SENTENCE).collect());
        let body = line.strip_prefix('$').ok_or_else(framing)?;
        let (body, stated) = body.rsplit_once('*').ok_or_else(framing)?;
        let stated = u8::from_str_radix(stated, 16).map_err(|_| framing())?;
        let computed = body.bytes().fold(0u8, |acc, b| acc ^ b);
        if stated != computed {
            return Err(NmeaError::Checksum { sentence: line.to_owned(), stated, computed });
        }
        let mut parts = body.split(',');
        let address = parts.next().unwrap_or_default().to_owned();
        Ok(Sentence { address, fields: parts.map(str::to_owned).collect() })
    }

    /// The sentence type without the talker (`GGA` for `GPGGA`, `GNGGA`, ...).
    pub fn kind(&self) -> &str {
        self.address.get(2..).unwrap_or_default()
    }
}

/// Splits a serial byte stream into sentence lines, counting what it drops.
#[derive(Clone, Debug, Default)]
pub struct NmeaReader {
    line: Vec<u8>,
    /// Characters dropped outside a sentence or in an overlong one.
    pub dropped_bytes: u64,
    /// Sentences dropped for running past [`MAX_SENTENCE`] without a line end.
    pub overlong: u64,
}

impl NmeaReader {
    pub fn new() -> NmeaReader {
        NmeaReader::default()
    }

    /// Feeds bytes; `each` receives every complete line that starts with `$` (not yet
    /// checksum-checked).
    pub fn push(&mut self, bytes: &[u8], mut each: impl FnMut(&str)) {
        for &b in bytes {
            match b {
                b'$' => {
                    self.dropped_bytes += self.line.len() as u64;
                    self.line.clear();
                    self.line.push(b);
                }
                b'\n' if !self.line.is_empty() => {
                    match std::str::from_utf8(&self.line) {
                        Ok(line) => each(line),
                        Err(_) => self.dropped_bytes += self.line.len() as u64,
                    }
                    self.line.clear();
                }
                _ if self.line.is_empty() => self.dropped_bytes += 1,
                _ if self.line.len() >= MAX_SENTENCE => {
                    self.overlong += 1;
                    self.dropped_bytes += self.line.len() as u64 + 1;
                    self.line.clear();
                }
                _ => self.line.push(b),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    #[test]
    fn splits_a_valid_sentence() {
        let s = Sentence::parse("$GPVTG,054.7,T,034.4,M,005.5,N,010.2,K*48\r\n").expect("valid");
        assert_eq!(s.address, "GPVTG");
        assert_eq!(s.kind(), "VTG");
        assert_eq!(s.fields, ["054.7", "T", "034.4", "M", "005.5", "N", "010.2", "K"]);
    }

    #[test]
    fn a_wrong_checksum_is_rejected() {
        let err = Sentence::parse("$GPVTG,054.7,T,034.4,M,005.5,N,010.2,K*49").expect_err("bad checksum");
        assert!(matches!(err, NmeaError::Checksum { stated: 0x49, computed: 0x48, .. }));
        assert!(matches!(Sentence::parse("GPVTG,054.7*48"), Err(NmeaError::Framing(_))));
        assert!(matches!(Sentence::parse("$GPVTG,054.7"), Err(NmeaError::Framing(_))));
    }

    #[test]
    fn the_reader_skips_binary_and_overlong_lines() {
        let mut reader = NmeaReader::new();
        let mut lines = Vec::new();
        let mut stream = vec![0xB5, 0x62, 0x01, 0x07];
        stream.extend_from_slice(b"$GPGGA,");
        stream.extend(std::iter::repeat_n(b'9', 200));
        stream.extend_from_slice(b"\r\n$GPVTG,054.7,T,034.4,M,005.5,N,010.2,K*48\r\n");
        reader.push(&stream, |l| lines.push(l.to_owned()));
        assert_eq!(lines, ["$GPVTG,054.7,T,034.4,M,005.5,N,010.2,K*48\r"]);
        assert!(reader.dropped_bytes >= 4 + 200);
        assert_eq!(reader.overlong, 1);
    }

    proptest! {
        #[test]
        fn never_panics_on_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
            let mut reader = NmeaReader::new();
            reader.push(&bytes, |line| { let _ = Sentence::parse(line); });
        }
    }
}
