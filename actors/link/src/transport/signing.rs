//! MAVLink 2 signing keys from files.

use std::path::Path;
use std::sync::Arc;

use mavlink::{SigningConfig, SigningData};

use super::EndpointError;

/// Loads a 32-byte key (raw, or as 64 hex digits) for a link that signs what it sends and
/// accepts only validly signed frames.
pub fn load(path: &Path, link_id: u8) -> Result<Arc<SigningData>, EndpointError> {
    let err = |reason: String| EndpointError::SigningKey { path: path.to_owned(), reason };
    let bytes = std::fs::read(path).map_err(|e| err(e.to_string()))?;
    let key = parse_key(&bytes).ok_or_else(|| err("expected 32 raw bytes or 64 hex digits".into()))?;
    Ok(Arc::new(SigningData::from_config(SigningConfig::new(key, link_id, true, false))))
}

fn parse_key(bytes: &[u8]) -> Option<[u8; 32]> {
    if let Ok(raw) = <[u8; 32]>::try_from(bytes) {
        return Some(raw);
    }
    let text = std::str::from_utf8(bytes).ok()?.trim();
    if text.len() != 64 {
        return None;
    }
    let mut key = [0u8; 32];
    for (i, k) in key.iter_mut().enumerate() {
        *k = u8::from_str_radix(text.get(2 * i..2 * i + 2)?, 16).ok()?;
    }
    Some(key)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raw_and_hex_keys_parse_and_others_do_not() {
        assert_eq!(parse_key(&[5u8; 32]), Some([5u8; 32]));
        let hex = "0a".repeat(32) + "\n";
        assert_eq!(parse_key(hex.as_bytes()), Some([10u8; 32]));
        assert_eq!(parse_key(b"short"), None);
        assert_eq!(parse_key("zz".repeat(32).as_bytes()), None);
    }
}
