//! SETUP_SIGNING from a ground station: a new key for the endpoint the message came through,
//! written to that endpoint's key file (so it survives a restart) and in force at once on every
//! link using that file. Taken only over a serial link (ArduPilot takes it over USB alone: on a
//! network link anyone who can reach the port could replace the key), only on an endpoint that
//! already signs (its key file is where the new key goes; like every frame there it must itself
//! pass the signature check), and never an all-zero key (ArduPilot's "signing off", which here
//! is removing `signing_key_file` from the config). Every outcome is a STATUSTEXT.

use mavlink::dialects::ardupilotmega::{MavMessage, MavSeverity, SETUP_SIGNING_DATA};

use super::signing::LinkSigning;
use super::signing_key::KeyError;
use crate::services::events::statustext;

/// Why a SETUP_SIGNING was not taken.
#[derive(Debug, thiserror::Error)]
pub enum SetupRefused {
    #[error("SETUP_SIGNING refused: not a serial link")]
    NotSecure,
    #[error("SETUP_SIGNING refused: link has no signing key")]
    NotSigning,
    #[error("SETUP_SIGNING refused: all-zero key")]
    ZeroKey,
    #[error("SETUP_SIGNING refused: key not stored")]
    NotStored(#[source] KeyError),
}

/// Installs the key `setup` carries through `link` (the link it arrived on).
pub fn install(link: Option<&LinkSigning>, setup: &SETUP_SIGNING_DATA) -> Result<(), SetupRefused> {
    let link = link.ok_or(SetupRefused::NotSigning)?;
    if !link.secure {
        return Err(SetupRefused::NotSecure);
    }
    if setup.secret_key == [0; 32] {
        return Err(SetupRefused::ZeroKey);
    }
    link.key.install(setup.secret_key).map_err(SetupRefused::NotStored)?;
    link.streams.advance_to(setup.initial_timestamp);
    Ok(())
}

/// [`install`], answered with the STATUSTEXT the ground station is sent.
pub fn handle(link: Option<&LinkSigning>, setup: &SETUP_SIGNING_DATA) -> MavMessage {
    match install(link, setup) {
        Ok(()) => {
            let path = link.map(|l| l.key.path().display().to_string()).unwrap_or_default();
            tracing::warn!(%path, "signing key replaced by SETUP_SIGNING");
            statustext(MavSeverity::MAV_SEVERITY_NOTICE, "Signing key installed")
        }
        Err(refused) => {
            tracing::warn!(error = %refused, source = ?std::error::Error::source(&refused), "SETUP_SIGNING");
            statustext(MavSeverity::MAV_SEVERITY_WARNING, &refused.to_string())
        }
    }
}

#[cfg(test)]
mod tests {
    use std::os::unix::fs::PermissionsExt;
    use std::sync::Arc;

    use super::*;
    use crate::transport::signing::{ONE_MINUTE, Streams};
    use crate::transport::signing_key::SigningKey;

    fn link(path: Option<&std::path::Path>, secure: bool) -> LinkSigning {
        let key = match path {
            Some(p) => SigningKey::load(p).expect("key"),
            None => SigningKey::for_tests([1; 32]),
        };
        LinkSigning { streams: Arc::new(Streams::new(None, 0)), key: Arc::new(key), link_id: 0, secure }
    }

    fn setup(key: [u8; 32], initial_timestamp: u64) -> SETUP_SIGNING_DATA {
        SETUP_SIGNING_DATA { initial_timestamp, target_system: 1, target_component: 1, secret_key: key }
    }

    fn text(m: &MavMessage) -> String {
        match m {
            MavMessage::STATUSTEXT(s) => {
                s.text.to_str().unwrap_or_default().trim_end_matches('\0').to_owned()
            }
            other => panic!("not a STATUSTEXT: {other:?}"),
        }
    }

    #[test]
    fn a_serial_link_installs_and_persists_the_key_and_the_timestamp() {
        let d = std::env::temp_dir().join(format!("kestrel-setup-{}", std::process::id()));
        std::fs::create_dir_all(&d).expect("dir");
        let path = d.join("radio.key");
        std::fs::write(&path, "01".repeat(32)).expect("key");
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o600)).expect("chmod");
        let serial = link(Some(&path), true);
        let answer = handle(Some(&serial), &setup([9; 32], 50 * ONE_MINUTE));
        assert_eq!(text(&answer), "Signing key installed");
        assert_eq!(serial.key.get(), [9; 32]);
        assert_eq!(SigningKey::load(&path).expect("stored").get(), [9; 32]);
        assert_eq!(serial.streams.timestamp(), 50 * ONE_MINUTE);
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn network_links_links_without_a_key_and_zero_keys_are_refused_with_the_reason() {
        let udp = link(None, false);
        let answer = handle(Some(&udp), &setup([9; 32], 0));
        assert_eq!(text(&answer), "SETUP_SIGNING refused: not a serial link");
        assert_eq!(udp.key.get(), [1; 32], "the key in force is unchanged");
        assert_eq!(text(&handle(None, &setup([9; 32], 0))), "SETUP_SIGNING refused: link has no signing key");
        let serial = link(None, true);
        assert_eq!(text(&handle(Some(&serial), &setup([0; 32], 0))), "SETUP_SIGNING refused: all-zero key");
        // The test key's file cannot be written: refused, and the old key stays.
        assert_eq!(text(&handle(Some(&serial), &setup([9; 32], 0))), "SETUP_SIGNING refused: key not stored");
        assert_eq!(serial.key.get(), [1; 32]);
    }
}
