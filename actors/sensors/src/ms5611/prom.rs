//! The MS5611's PROM: 8 words of 16 bits — a factory word, the six calibration coefficients
//! C1..C6 and a serial/CRC word whose low 4 bits are a CRC-4 over the other 124 bits
//! (datasheet "PROM read sequence" / "Cyclic redundancy check (CRC)"; algorithm from
//! application note AN520, "C-code example for MS56xx, MS57xx (except analog sensor) and
//! MS58xx series pressure sensors").

/// Why a PROM image was rejected.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PromError {
    /// Every word read as 0x0000 or every word as 0xFFFF: nothing answered on the bus.
    #[error("PROM reads all {0:#06x}: no MS5611 answering")]
    Blank(u16),
    /// The stored CRC does not match the one computed over the PROM.
    #[error("PROM CRC-4 mismatch: stored {stored:#x}, computed {computed:#x}")]
    Crc { stored: u8, computed: u8 },
}

/// The CRC-4 of AN520 over a PROM image: polynomial 0x3000 on a 16-bit remainder, fed the 16
/// bytes of the 8 words most significant byte first with the CRC nibble (low 4 bits of word 7)
/// and the rest of its low byte taken as zero. Returns the 4-bit CRC.
pub fn crc4(words: &[u16; 8]) -> u8 {
    let mut prom = *words;
    prom[7] &= 0xFF00;
    let mut rem: u16 = 0;
    for cnt in 0..16 {
        let word = prom[cnt >> 1];
        rem ^= if cnt % 2 == 1 { word & 0x00FF } else { word >> 8 };
        for _ in 0..8 {
            rem = if rem & 0x8000 != 0 { (rem << 1) ^ 0x3000 } else { rem << 1 };
        }
    }
    ((rem >> 12) & 0x000F) as u8
}

/// A PROM image whose CRC checked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Prom {
    words: [u16; 8],
}

impl Prom {
    /// Checks `words` (PROM addresses 0..7, as read with commands 0xA0..0xAE).
    pub fn new(words: [u16; 8]) -> Result<Prom, PromError> {
        for blank in [0x0000, 0xFFFF] {
            if words.iter().all(|&w| w == blank) {
                return Err(PromError::Blank(blank));
            }
        }
        let stored = (words[7] & 0x000F) as u8;
        let computed = crc4(&words);
        if stored != computed {
            return Err(PromError::Crc { stored, computed });
        }
        Ok(Prom { words })
    }

    /// Calibration coefficient `C1`..`C6` (`index` 1..=6) as the datasheet numbers them.
    pub fn c(&self, index: usize) -> u16 {
        self.words[index]
    }

    /// The raw words.
    pub fn words(&self) -> [u16; 8] {
        self.words
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The datasheet's example coefficients (C1..C6 = 40127, 36924, 23317, 23282, 33464,
    /// 28312) with a factory word and their own CRC in word 7.
    pub(crate) fn datasheet_prom_words() -> [u16; 8] {
        let mut words = [0x0040, 40127, 36924, 23317, 23282, 33464, 28312, 0x1230];
        words[7] |= u16::from(crc4(&words));
        words
    }

    #[test]
    fn crc_ignores_its_own_nibble_and_the_low_byte_of_word_7() {
        let mut words = datasheet_prom_words();
        let crc = crc4(&words);
        words[7] = (words[7] & 0xFF00) | 0x00FF;
        assert_eq!(crc4(&words), crc);
    }

    #[test]
    fn a_prom_with_its_crc_is_accepted() {
        let prom = Prom::new(datasheet_prom_words()).expect("valid PROM");
        assert_eq!(prom.c(1), 40127);
        assert_eq!(prom.c(6), 28312);
    }

    #[test]
    fn every_single_bit_flip_is_caught() {
        let words = datasheet_prom_words();
        for word in 0..8 {
            for bit in 0..16 {
                if word == 7 && bit < 8 {
                    continue; // the CRC nibble and the unused low bits are outside the sum
                }
                let mut bad = words;
                bad[word] ^= 1 << bit;
                assert!(
                    matches!(Prom::new(bad), Err(PromError::Crc { .. })),
                    "flip of word {word} bit {bit} went unnoticed"
                );
            }
        }
    }

    #[test]
    fn a_silent_bus_is_blank_not_a_crc_error() {
        assert_eq!(Prom::new([0xFFFF; 8]), Err(PromError::Blank(0xFFFF)));
        assert_eq!(Prom::new([0; 8]), Err(PromError::Blank(0)));
    }
}
