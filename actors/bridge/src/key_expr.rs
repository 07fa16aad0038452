//! Zenoh key expressions of bridged topics: `kestrel/<vehicle>/<topic>`, so a fleet's topics
//! are told apart by vehicle and one subscriber to `kestrel/*/nav_state` sees every vehicle.

use crate::error::BridgeError;

/// The first chunk of every Kestrel key expression.
pub const ROOT: &str = "kestrel";

/// Longest vehicle or topic name: a hostname label's length, so a vehicle may be named after its
/// host.
pub const MAX_CHUNK_LEN: usize = 63;

/// Checks that `chunk` can stand alone between two `/` of a key expression and match only
/// itself: ASCII letters, digits, `_` and `-`, not empty. Zenoh's wildcards (`*`, `**`, `$*`),
/// its separators and verbatim marker (`/`, `@`) and the selector's `?`, `#` are refused.
pub fn check_chunk(what: &'static str, chunk: &str) -> Result<(), BridgeError> {
    if chunk.is_empty() {
        return Err(BridgeError::Name { what, name: chunk.into(), why: "is empty".into() });
    }
    if chunk.len() > MAX_CHUNK_LEN {
        return Err(BridgeError::Name {
            what,
            name: chunk.into(),
            why: format!("is longer than {MAX_CHUNK_LEN} characters"),
        });
    }
    if let Some(c) = chunk.chars().find(|c| !(c.is_ascii_alphanumeric() || *c == '_' || *c == '-')) {
        return Err(BridgeError::Name {
            what,
            name: chunk.into(),
            why: format!("holds {c:?}; only ASCII letters, digits, '_' and '-' are allowed"),
        });
    }
    Ok(())
}

/// The key expression of `topic` on `vehicle`, both checked with [`check_chunk`].
pub fn topic_key(vehicle: &str, topic: &str) -> Result<String, BridgeError> {
    check_chunk("vehicle", vehicle)?;
    check_chunk("topic", topic)?;
    Ok(format!("{ROOT}/{vehicle}/{topic}"))
}

/// The vehicle and topic of a key expression built by [`topic_key`]; `None` for any other key.
pub fn parse_topic_key(key: &str) -> Option<(&str, &str)> {
    let mut chunks = key.split('/');
    match (chunks.next(), chunks.next(), chunks.next(), chunks.next()) {
        (Some(ROOT), Some(vehicle), Some(topic), None)
            if check_chunk("vehicle", vehicle).is_ok() && check_chunk("topic", topic).is_ok() =>
        {
            Some((vehicle, topic))
        }
        _ => None,
    }
}

/// The vehicle name of `--instance n`: `<vehicle>-<n>`, so instances of one config differ.
pub fn instance_vehicle(vehicle: &str, instance: Option<u8>) -> String {
    match instance {
        Some(n) => format!("{vehicle}-{n}"),
        None => vehicle.to_owned(),
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    #[test]
    fn a_topic_key_names_the_vehicle_and_the_topic() {
        assert_eq!(topic_key("kestrel-1", "nav_state").unwrap(), "kestrel/kestrel-1/nav_state");
        assert_eq!(parse_topic_key("kestrel/kestrel-1/nav_state"), Some(("kestrel-1", "nav_state")));
        assert_eq!(instance_vehicle("quad", Some(3)), "quad-3");
        assert_eq!(instance_vehicle("quad", None), "quad");
    }

    #[test]
    fn wildcards_separators_and_empty_names_are_refused_with_the_reason() {
        for (name, why) in [
            ("", "is empty"),
            ("*", "'*'"),
            ("a/b", "'/'"),
            ("$*", "'$'"),
            ("a?b", "'?'"),
            ("v#1", "'#'"),
            ("@admin", "'@'"),
            ("drône", "'ô'"),
        ] {
            let e = topic_key(name, "nav_state").unwrap_err().to_string();
            assert!(e.contains("vehicle") && e.contains(why), "{name:?}: {e}");
            let e = topic_key("v", name).unwrap_err().to_string();
            assert!(e.contains("topic") && e.contains(why), "{name:?}: {e}");
        }
        let long = "v".repeat(MAX_CHUNK_LEN + 1);
        assert!(topic_key(&long, "t").unwrap_err().to_string().contains("longer than 63"));
        for key in ["kestrel/a", "kestrel/a/b/c", "other/a/b", "kestrel/*/b", "kestrel//b"] {
            assert_eq!(parse_topic_key(key), None, "{key}");
        }
    }

    proptest! {
        #[test]
        fn every_valid_key_parses_back_and_is_a_valid_zenoh_key(
            vehicle in "[A-Za-z0-9_-]{1,20}",
            topic in "[a-z_]{1,20}",
        ) {
            let key = topic_key(&vehicle, &topic).unwrap();
            prop_assert_eq!(parse_topic_key(&key), Some((vehicle.as_str(), topic.as_str())));
            let parsed = zenoh::key_expr::KeyExpr::try_from(key.as_str());
            prop_assert!(parsed.is_ok(), "{}", key);
            // Matches only itself: no wildcard slipped in.
            let wild = zenoh::key_expr::KeyExpr::try_from(format!("{ROOT}/*/{topic}")).unwrap();
            prop_assert!(wild.intersects(&parsed.unwrap()));
        }
    }
}
