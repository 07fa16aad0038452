//! `@PARAM/param.pck`: every parameter in one small file, the format ArduPilot's
//! `AP_Filesystem_Param` serves over MAVLink FTP and MAVProxy (`param_ftp.py`) and
//! QGroundControl decode for a fast parameter download.
//!
//! Layout, little-endian: a header `magic: u16 = 0x671b, num_params: u16, total_params: u16`,
//! then per parameter in index order one byte `type` (low nibble: 1 int8, 2 int16, 3 int32,
//! 4 float; high nibble: flags, 0 here as no defaults are sent), one byte `name_len - 1` (high
//! nibble) and `common_len` (low nibble: leading bytes shared with the previous name, which
//! are not repeated), the name's remaining bytes, then the value. Zero bytes between entries
//! are padding readers skip; we pad so that no entry crosses a 256-byte boundary, so a reader
//! holding any aligned 256-byte window decodes whole entries (ArduPilot pads by its FTP read
//! size for the same reason).
//!
//! Held by `param_pack::tests` (decoded by an independent reader written from MAVProxy's
//! decoder) and by `tests/gcs_log_download.rs` (pymavlink's own decoder over FTP).

use mavlink::dialects::ardupilotmega::{MavMessage, MavParamType};

/// The header's magic number for a file without defaults.
pub const MAGIC: u16 = 0x671b;

/// A parameter name is at most 16 bytes (PARAM_VALUE's `param_id`).
const NAME_MAX: usize = 16;

/// The file for `values`, PARAM_VALUEs in index order (what PARAM_REQUEST_LIST sends).
pub fn encode(values: &[MavMessage]) -> Vec<u8> {
    let params: Vec<_> = values
        .iter()
        .filter_map(|m| match m {
            MavMessage::PARAM_VALUE(v) => Some(v),
            _ => None,
        })
        .collect();
    let count = u16::try_from(params.len()).unwrap_or(u16::MAX);
    let mut out = Vec::with_capacity(6 + params.len() * 12);
    out.extend_from_slice(&MAGIC.to_le_bytes());
    out.extend_from_slice(&count.to_le_bytes());
    out.extend_from_slice(&count.to_le_bytes());
    let mut last: &[u8] = &[];
    for p in params.iter().take(usize::from(count)) {
        let len = p.param_id.iter().position(|&b| b == 0).unwrap_or(NAME_MAX).min(NAME_MAX);
        let name = &p.param_id[..len];
        if name.is_empty() {
            continue;
        }
        let (kind, value) = packed_value(p.param_type, p.param_value);
        // At most 15 shared bytes (a nibble), and at least one byte of name left to write.
        let common = name.iter().zip(last).take_while(|(a, b)| a == b).count().min(15).min(name.len() - 1);
        let suffix = &name[common..];
        let entry_len = 2 + suffix.len() + value.len();
        let boundary_left = 256 - out.len() % 256;
        if entry_len > boundary_left {
            out.resize(out.len() + boundary_left, 0);
        }
        out.push(kind);
        // `suffix` is 1..=16 bytes, `common` at most 15: both fit their nibble.
        out.push((((suffix.len() - 1) as u8) << 4) | common as u8);
        out.extend_from_slice(suffix);
        out.extend_from_slice(&value);
        last = name;
    }
    out
}

/// The packed type and bytes of a parameter value: integers in the smallest of int8/int16/int32
/// holding the value (an unsigned byte above 127 needs int16), floats as float.
fn packed_value(kind: MavParamType, value: f32) -> (u8, Vec<u8>) {
    use MavParamType::*;
    let integer = matches!(
        kind,
        MAV_PARAM_TYPE_UINT8
            | MAV_PARAM_TYPE_INT8
            | MAV_PARAM_TYPE_UINT16
            | MAV_PARAM_TYPE_INT16
            | MAV_PARAM_TYPE_UINT32
            | MAV_PARAM_TYPE_INT32
    );
    if integer && value.fract() == 0.0 {
        let v = value as i64;
        if let Ok(v) = i8::try_from(v) {
            return (1, v.to_le_bytes().to_vec());
        }
        if let Ok(v) = i16::try_from(v) {
            return (2, v.to_le_bytes().to_vec());
        }
        if let Ok(v) = i32::try_from(v) {
            return (3, v.to_le_bytes().to_vec());
        }
    }
    (4, value.to_le_bytes().to_vec())
}

#[cfg(test)]
mod tests {
    use super::*;
    use mavlink::dialects::ardupilotmega::PARAM_VALUE_DATA;

    fn value(name: &str, v: f32, kind: MavParamType) -> MavMessage {
        let mut param_id = [0u8; 16];
        param_id[..name.len()].copy_from_slice(name.as_bytes());
        MavMessage::PARAM_VALUE(PARAM_VALUE_DATA {
            param_value: v,
            param_count: 0,
            param_index: 0,
            param_id: param_id.into(),
            param_type: kind,
        })
    }

    /// An independent reader, written from the format as MAVProxy decodes it.
    fn decode(data: &[u8]) -> (u16, u16, Vec<(String, f64)>) {
        let magic = u16::from_le_bytes([data[0], data[1]]);
        assert_eq!(magic, MAGIC);
        let num = u16::from_le_bytes([data[2], data[3]]);
        let total = u16::from_le_bytes([data[4], data[5]]);
        let mut i = 6;
        let mut last = Vec::new();
        let mut out = Vec::new();
        while i < data.len() {
            if data[i] == 0 {
                i += 1;
                continue;
            }
            let kind = data[i] & 0x0f;
            let name_len = usize::from(data[i + 1] >> 4) + 1;
            let common = usize::from(data[i + 1] & 0x0f);
            let mut name = last[..common].to_vec();
            name.extend_from_slice(&data[i + 2..i + 2 + name_len]);
            let v = &data[i + 2 + name_len..];
            let (value, size) = match kind {
                1 => (f64::from(v[0] as i8), 1),
                2 => (f64::from(i16::from_le_bytes([v[0], v[1]])), 2),
                3 => (f64::from(i32::from_le_bytes([v[0], v[1], v[2], v[3]])), 4),
                4 => (f64::from(f32::from_le_bytes([v[0], v[1], v[2], v[3]])), 4),
                k => panic!("bad type {k}"),
            };
            let start = i;
            i += 2 + name_len + size;
            assert_eq!(start / 256, (i - 1) / 256, "an entry crosses a 256-byte boundary at {start}");
            out.push((String::from_utf8(name.clone()).expect("ascii"), value));
            last = name;
        }
        (num, total, out)
    }

    #[test]
    fn every_value_decodes_back_with_shared_prefixes_and_the_smallest_integer_type() {
        use MavParamType::*;
        let values = vec![
            value("ATC_ANG_PIT_P", 4.5, MAV_PARAM_TYPE_REAL32),
            value("ATC_ANG_RLL_P", 4.5, MAV_PARAM_TYPE_REAL32),
            value("FENCE_ENABLE", 1.0, MAV_PARAM_TYPE_INT8),
            value("MAV_GCS_SYSID", 255.0, MAV_PARAM_TYPE_UINT8),
            value("RTL_ALT_M", -30.0, MAV_PARAM_TYPE_INT32),
            value("SIXTEEN_LETTERS_", 70000.0, MAV_PARAM_TYPE_INT32),
            value("SIXTEEN_LETTERS_", 1.25, MAV_PARAM_TYPE_REAL32),
        ];
        let data = encode(&values);
        let (num, total, got) = decode(&data);
        assert_eq!((num, total), (7, 7));
        let want: Vec<(String, f64)> = vec![
            ("ATC_ANG_PIT_P".into(), 4.5),
            ("ATC_ANG_RLL_P".into(), 4.5),
            ("FENCE_ENABLE".into(), 1.0),
            ("MAV_GCS_SYSID".into(), 255.0),
            ("RTL_ALT_M".into(), -30.0),
            ("SIXTEEN_LETTERS_".into(), 70000.0),
            ("SIXTEEN_LETTERS_".into(), 1.25),
        ];
        assert_eq!(got, want);
        // The second name repeats 8 bytes of the first ("ATC_ANG_").
        assert_eq!(data[6 + 2 + 13 + 4 + 1] & 0x0f, 8);
        assert_eq!(data[6 + 2 + 13 + 4] & 0x0f, 4, "float");
        assert_eq!(data[6 + 2 + 13 + 4 + 2 + 5 + 4] & 0x0f, 1, "int8");
    }

    #[test]
    fn no_entry_crosses_a_256_byte_boundary() {
        let values: Vec<_> = (0..200)
            .map(|i| {
                value(
                    &format!("P{i:03}_LONG_NAME_{}", i % 10),
                    i as f32 * 0.5,
                    MavParamType::MAV_PARAM_TYPE_REAL32,
                )
            })
            .collect();
        let data = encode(&values);
        let (num, _, got) = decode(&data);
        assert_eq!((usize::from(num), got.len()), (200, 200));
        assert!(data.len() > 256 * 4);
    }
}
