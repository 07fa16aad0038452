//! Who may send the topics that move the motors (`vehicle_command`, `avoidance_command`,
//! `setpoint`): the Zenoh ids listed in the bridge's `command_sources`, checked on every sample
//! as a second line behind Zenoh's own access control.
//!
//! What a Zenoh sample says about its sender: nothing Zenoh authenticated. The transport a
//! sample came in on is authenticated (a user/password, a TLS certificate), but that identity
//! is seen only by Zenoh's access control, which refuses a put from a peer its rules do not
//! allow before the bridge sees it (`access_control` in the Zenoh config file). What reaches
//! the bridge is the sample's timestamp, whose id is the Zenoh id (zid) of the session that
//! stamped it (`session.new_timestamp()`, as the bridge and the Python client do). The bridge
//! takes a motor topic only when that id is listed, so a peer the access control lets through
//! by mistake (a rule too wide, `default_permission: "allow"`) still cannot command the
//! vehicle unless it also claims a listed id; a sample with no timestamp names no one and is
//! refused. The id is claimed by the sender, not proven: the access control is the fence, this
//! is the second look.

use crate::error::BridgeError;

/// A Zenoh id, as `u128::from_le_bytes` of its bytes (how Zenoh prints it: lowercase hex, no
/// leading zeros).
pub type ZenohId = u128;

/// Parses a Zenoh id as Zenoh writes it (`38a4829bce9166ee`): 1 to 32 lowercase hex digits, no
/// leading zero (Zenoh refuses those too, so an id that parses here is one Zenoh accepts).
pub fn parse_zenoh_id(text: &str) -> Result<ZenohId, String> {
    let why = if text.is_empty() || text.len() > 32 {
        "is not 1 to 32 hex digits"
    } else if !text.chars().all(|c| c.is_ascii_digit() || ('a'..='f').contains(&c)) {
        "holds a character that is not a lowercase hex digit"
    } else if text.starts_with('0') {
        "starts with 0 (Zenoh writes ids without leading zeros, and refuses them)"
    } else {
        return u128::from_str_radix(text, 16).map_err(|e| format!("zenoh id {text:?}: {e}"));
    };
    Err(format!("zenoh id {text:?} {why}"))
}

/// The ids that may send motor topics.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CommandSources {
    ids: Vec<ZenohId>,
}

/// Why a motor topic's sample was refused.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SourceRefusal {
    /// No timestamp, so no sender id.
    #[error("it names no sender (no timestamp; stamp it with session.new_timestamp())")]
    Unnamed,
    /// A sender id `command_sources` does not list.
    #[error("sender {0:x} is not in command_sources")]
    NotListed(ZenohId),
}

impl CommandSources {
    /// The `command_sources` parameter, each id checked.
    pub fn parse(list: &[String]) -> Result<CommandSources, BridgeError> {
        let mut ids = Vec::with_capacity(list.len());
        for text in list {
            let id =
                parse_zenoh_id(text).map_err(|why| BridgeError::Param { param: "command_sources", why })?;
            if ids.contains(&id) {
                return Err(BridgeError::Param {
                    param: "command_sources",
                    why: format!("zenoh id {text:?} is listed twice"),
                });
            }
            ids.push(id);
        }
        Ok(CommandSources { ids })
    }

    /// Whether none is listed (then no motor topic may be subscribed).
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// Whether a motor topic's sample from `sender` (its timestamp's id, if it has one) is taken.
    pub fn admit(&self, sender: Option<ZenohId>) -> Result<(), SourceRefusal> {
        match sender {
            None => Err(SourceRefusal::Unnamed),
            Some(id) if self.ids.contains(&id) => Ok(()),
            Some(id) => Err(SourceRefusal::NotListed(id)),
        }
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    fn sources(ids: &[&str]) -> CommandSources {
        CommandSources::parse(&ids.iter().map(|s| s.to_string()).collect::<Vec<_>>()).unwrap()
    }

    #[test]
    fn ids_parse_as_zenoh_writes_them_and_bad_ones_are_named() {
        assert_eq!(parse_zenoh_id("1"), Ok(1));
        assert_eq!(parse_zenoh_id("38a4829bce9166ee"), Ok(0x38a4_829b_ce91_66ee));
        assert_eq!(parse_zenoh_id(&"f".repeat(32)), Ok(u128::MAX));
        for (bad, why) in [
            ("", "is not 1 to 32 hex digits"),
            (&"1".repeat(33), "is not 1 to 32 hex digits"),
            ("38A4", "not a lowercase hex digit"),
            ("gcs", "not a lowercase hex digit"),
            ("0a", "starts with 0"),
        ] {
            let e = parse_zenoh_id(bad).unwrap_err();
            assert!(e.contains(why) && e.contains(&format!("{bad:?}")), "{bad}: {e}");
        }
        let twice = CommandSources::parse(&["a1".into(), "a1".into()]).unwrap_err().to_string();
        assert!(twice.contains("parameter 'command_sources': zenoh id \"a1\" is listed twice"), "{twice}");
        let bad = CommandSources::parse(&["A1".into()]).unwrap_err().to_string();
        assert!(bad.contains("parameter 'command_sources'"), "{bad}");
    }

    #[test]
    fn only_a_listed_sender_is_admitted_and_an_unnamed_one_never() {
        let s = sources(&["a1", "4b7e"]);
        assert_eq!(s.admit(Some(0xa1)), Ok(()));
        assert_eq!(s.admit(Some(0x4b7e)), Ok(()));
        assert_eq!(s.admit(Some(0xa2)), Err(SourceRefusal::NotListed(0xa2)));
        assert_eq!(s.admit(None), Err(SourceRefusal::Unnamed));
        assert_eq!(SourceRefusal::NotListed(0xa2).to_string(), "sender a2 is not in command_sources");
        assert_eq!(CommandSources::default().admit(Some(0xa1)), Err(SourceRefusal::NotListed(0xa1)));
    }

    proptest! {
        /// An id prints as Zenoh prints it and parses back; a sender is admitted exactly when
        /// it is listed.
        #[test]
        fn admission_is_membership(listed in prop::collection::vec(1u128.., 0..5), sender in prop::option::of(1u128..)) {
            let mut listed = listed;
            listed.sort_unstable();
            listed.dedup();
            let texts: Vec<String> = listed.iter().map(|id| format!("{id:x}")).collect();
            let s = CommandSources::parse(&texts).unwrap();
            prop_assert_eq!(s.admit(sender).is_ok(), sender.is_some_and(|id| listed.contains(&id)));
        }
    }
}
