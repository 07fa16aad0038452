//! Careless and hostile edits of a valid input file, for the property tests that feed every
//! input format the CLI reads to its parser: each edit must give an error or a result, never a
//! panic or an abort.
//!
//! The edits are plain data (`(kind, position, byte)` triples a property test draws at random),
//! so every format's test shares one list of what a person or a broken disk does to a file.

/// Values a numeric field is replaced with: non-finite, huge, negative, zero, too wide for any
/// integer type, and the spellings of NaN and infinity in TOML, JSON, YAML and Rust.
pub const EXTREME_NUMBERS: &[&str] = &[
    "nan",
    "NaN",
    "inf",
    "-inf",
    ".inf",
    "-.inf",
    ".nan",
    "1e30",
    "-1e30",
    "1e308",
    "-1",
    "0",
    "-0",
    "1000000000000",
    "18446744073709551616",
    "-9223372036854775809",
    "4294967296",
    "1e-300",
    "null",
];

/// `valid` after applying each `(kind, position, byte)` edit in turn: flip a byte, cut the file
/// short, delete or duplicate a line, replace a number with one of [`EXTREME_NUMBERS`], insert
/// a byte. `position` picks the place modulo what there is.
pub fn mutate(valid: &[u8], edits: &[(u8, usize, u8)]) -> Vec<u8> {
    let mut data = valid.to_vec();
    for &(kind, position, byte) in edits {
        match kind % 6 {
            0 if !data.is_empty() => {
                let i = position % data.len();
                data[i] ^= byte.max(1);
            }
            1 => data.truncate(position % (data.len() + 1)),
            2 | 3 => {
                let lines: Vec<&[u8]> = data.split_inclusive(|&b| b == b'\n').collect();
                if lines.is_empty() {
                    continue;
                }
                let k = position % lines.len();
                let mut out = Vec::with_capacity(data.len() + lines[k].len());
                for (i, line) in lines.iter().enumerate() {
                    if i != k || kind % 6 == 3 {
                        out.extend_from_slice(line);
                    }
                    if i == k && kind % 6 == 3 {
                        out.extend_from_slice(line);
                    }
                }
                data = out;
            }
            4 => {
                let numbers = number_spans(&data);
                if numbers.is_empty() {
                    continue;
                }
                let (start, end) = numbers[position % numbers.len()];
                let value = EXTREME_NUMBERS[usize::from(byte) % EXTREME_NUMBERS.len()];
                data.splice(start..end, value.bytes());
            }
            _ => {
                let i = position % (data.len() + 1);
                data.insert(i, byte);
            }
        }
    }
    data
}

/// Byte ranges of the numbers in `data`: a digit run with its sign, point and exponent.
fn number_spans(data: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut i = 0;
    while i < data.len() {
        let starts_word = i == 0 || !(data[i - 1].is_ascii_alphanumeric() || data[i - 1] == b'_');
        if data[i].is_ascii_digit() && starts_word {
            let start = if i > 0 && data[i - 1] == b'-' { i - 1 } else { i };
            let mut end = i;
            while end < data.len() && (data[end].is_ascii_digit() || b".eE+-".contains(&data[end])) {
                end += 1;
            }
            spans.push((start, end));
            i = end;
        } else {
            i += 1;
        }
    }
    spans
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_edit_does_what_it_says() {
        let text = b"a = 1\nb = -2.5e3\n";
        assert_eq!(mutate(text, &[(1, 3, 0)]), b"a =");
        assert_eq!(mutate(text, &[(2, 0, 0)]), b"b = -2.5e3\n");
        assert_eq!(mutate(text, &[(3, 1, 0)]), b"a = 1\nb = -2.5e3\nb = -2.5e3\n");
        assert_eq!(mutate(text, &[(4, 1, 2)]), b"a = 1\nb = inf\n");
        assert_eq!(mutate(text, &[(0, 0, 0x20)]), b"A = 1\nb = -2.5e3\n");
        assert_eq!(mutate(b"", &[(0, 5, 1), (2, 0, 0), (4, 0, 0)]), b"");
    }
}
