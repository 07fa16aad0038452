//! The bridge's Zenoh config file (`zenoh_config`, json5 as Zenoh's own): who may connect
//! (`transport.auth.usrpwd`) and what each peer may do (`access_control`), enforced by Zenoh
//! itself. The graph's bridge parameters keep what the graph decides (`mode`, `connect`,
//! `listen`, multicast scouting); the file may not set those, so one place says where a vehicle
//! listens. Relative file paths in it (the user/password dictionary) are read from the file's
//! own directory, as the graph config's paths are from the graph's.

use std::path::{Path, PathBuf};

use serde_json::Value;
use zenoh::Config;

use crate::error::BridgeError;

/// Fields of a Zenoh config the graph's bridge parameters set, each with its parameter.
const GRAPH_FIELDS: &[(&str, &str)] = &[
    ("mode", "mode"),
    ("connect/endpoints", "connect"),
    ("listen/endpoints", "listen"),
    ("scouting/multicast/enabled", "scouting"),
];

/// The user/password dictionary's field (one `user:password` a line).
const DICTIONARY: &str = "transport/auth/usrpwd/dictionary_file";

/// A loaded Zenoh config file and what the bridge needs to know of it.
#[derive(Debug)]
pub struct ZenohFile {
    pub path: PathBuf,
    pub config: Config,
    /// `access_control.enabled` with `default_permission: "deny"`: a peer no rule names can do
    /// nothing.
    pub denies_by_default: bool,
    /// Warnings to log at start (a credential file others may read).
    pub warnings: Vec<String>,
}

/// Reads and checks the Zenoh config at `path` (relative to `config_dir`).
pub fn load(config_dir: &Path, path: &str) -> Result<ZenohFile, BridgeError> {
    let path = config_dir.join(path);
    let error =
        |field: &str, why: String| BridgeError::ZenohConfig { file: path.clone(), field: field.into(), why };
    let text = std::fs::read_to_string(&path).map_err(|e| error("", format!("cannot be read: {e}")))?;
    let mut config = Config::from_json5(&text).map_err(|e| error("", e.to_string()))?;
    let default = Config::default();
    for (field, param) in GRAPH_FIELDS {
        if get(&config, field) != get(&default, field) {
            return Err(error(
                field,
                format!("is set by the graph config's bridge parameter `{param}`; leave it out of this file"),
            ));
        }
    }
    if get(&config, "transport/link/tls") != get(&default, "transport/link/tls") {
        return Err(error(
            "transport/link/tls",
            "this kestrel's Zenoh has no TLS link (only tcp, see actors/bridge/Cargo.toml); \
             use transport.auth.usrpwd"
                .into(),
        ));
    }
    let mut warnings = Vec::new();
    let dictionary = match get(&config, DICTIONARY) {
        Value::String(file) => {
            let resolved = path.parent().unwrap_or(Path::new(".")).join(&file);
            let metadata = std::fs::metadata(&resolved)
                .map_err(|e| error(DICTIONARY, format!("{}: {e}", resolved.display())))?;
            if let Some(warning) = shared_credentials(&resolved, &metadata) {
                warnings.push(warning);
            }
            let resolved_text = resolved.to_str().ok_or_else(|| error(DICTIONARY, "is not UTF-8".into()))?;
            let json = serde_json::to_string(resolved_text).map_err(|e| error(DICTIONARY, e.to_string()))?;
            config.insert_json5(DICTIONARY, &json).map_err(|e| error(DICTIONARY, e.to_string()))?;
            true
        }
        _ => false,
    };
    if matches!(get(&config, "transport/auth/usrpwd/password"), Value::String(_))
        && let Ok(metadata) = std::fs::metadata(&path)
        && let Some(warning) = shared_credentials(&path, &metadata)
    {
        warnings.push(warning);
    }
    let acl = get(&config, "access_control");
    let enabled = acl.get("enabled") == Some(&Value::Bool(true));
    // Zenoh's default permission is deny when the field is left out.
    let denies_by_default = match acl.get("default_permission") {
        None | Some(Value::Null) => true,
        Some(permission) => permission.as_str() == Some("deny"),
    };
    let names_users = acl
        .get("subjects")
        .and_then(Value::as_array)
        .is_some_and(|subjects| subjects.iter().any(|s| s.get("usernames").is_some_and(|u| !u.is_null())));
    if enabled && names_users && !dictionary {
        return Err(error(
            "access_control/subjects",
            format!("names usernames, but no `{DICTIONARY}` authenticates them"),
        ));
    }
    Ok(ZenohFile { path, config, denies_by_default: enabled && denies_by_default, warnings })
}

/// The JSON value of `field` (null when Zenoh has none).
fn get(config: &Config, field: &str) -> Value {
    config.get_json(field).ok().and_then(|json| serde_json::from_str(&json).ok()).unwrap_or(Value::Null)
}

/// A warning when a file holding passwords is readable by its group or by anyone (`chmod 600`
/// makes it the owner's alone, as ssh wants of a private key).
#[cfg(unix)]
fn shared_credentials(path: &Path, metadata: &std::fs::Metadata) -> Option<String> {
    use std::os::unix::fs::PermissionsExt;
    let mode = metadata.permissions().mode() & 0o777;
    (mode & 0o077 != 0).then(|| {
        format!(
            "{} holds passwords and is readable by others (mode {mode:o}); chmod 600 it on a vehicle",
            path.display()
        )
    })
}

#[cfg(not(unix))]
fn shared_credentials(_path: &Path, _metadata: &std::fs::Metadata) -> Option<String> {
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(test: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("kestrel-zenoh-file-{}-{test}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    const ACL: &str = r#"access_control: { enabled: true, default_permission: "deny", rules: [
        { id: "cmd", messages: ["put"], flows: ["ingress"], permission: "allow", key_exprs: ["kestrel/*/vehicle_command"] } ],
        subjects: [ { id: "gcs", usernames: ["gcs"] } ], policies: [ { rules: ["cmd"], subjects: ["gcs"] } ] }"#;

    #[test]
    fn a_file_with_a_dictionary_and_an_acl_loads_with_the_dictionary_beside_it() {
        let dir = temp_dir("good");
        std::fs::create_dir_all(dir.join("zenoh")).unwrap();
        std::fs::write(dir.join("zenoh/users.txt"), "gcs:secret\n").unwrap();
        let text =
            format!("{{ transport: {{ auth: {{ usrpwd: {{ dictionary_file: \"users.txt\" }} }} }}, {ACL} }}");
        std::fs::write(dir.join("zenoh/vehicle.json5"), text).unwrap();
        let file = load(&dir, "zenoh/vehicle.json5").unwrap();
        assert!(file.denies_by_default);
        let resolved = get(&file.config, DICTIONARY);
        assert_eq!(resolved, Value::String(dir.join("zenoh/users.txt").display().to_string()));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn each_bad_file_is_refused_naming_the_file_and_the_field() {
        let dir = temp_dir("bad");
        std::fs::write(dir.join("users.txt"), "gcs:secret\n").unwrap();
        let cases: &[(&str, &str, &str)] = &[
            (
                "{ listen: { endpoints: [\"tcp/0.0.0.0:7447\"] } }",
                "listen/endpoints",
                "bridge parameter `listen`",
            ),
            ("{ mode: \"client\" }", "mode", "bridge parameter `mode`"),
            ("{ connect: { endpoints: [\"tcp/1.2.3.4:7447\"] } }", "connect/endpoints", "`connect`"),
            (
                "{ transport: { link: { tls: { root_ca_certificate: \"ca.pem\" } } } }",
                "transport/link/tls",
                "no TLS link",
            ),
            (
                "{ transport: { auth: { usrpwd: { dictionary_file: \"missing.txt\" } } } }",
                DICTIONARY,
                "missing.txt",
            ),
            (
                "{ access_control: { enabled: true, subjects: [ { id: \"s\", usernames: [\"gcs\"] } ] } }",
                "access_control/subjects",
                "no `transport/auth/usrpwd/dictionary_file`",
            ),
            ("{ transprt: {} }", "", "transprt"),
            ("{ mode: ", "", ""),
        ];
        for (text, field, why) in cases {
            std::fs::write(dir.join("z.json5"), text).unwrap();
            let e = load(&dir, "z.json5").unwrap_err();
            let BridgeError::ZenohConfig { file, field: got, .. } = &e else { panic!("{e}") };
            assert_eq!((file, got.as_str()), (&dir.join("z.json5"), *field), "{text}: {e}");
            let message = e.to_string();
            assert!(message.contains("z.json5") && message.contains(why), "{text}: {message}");
        }
        let missing = load(&dir, "none.json5").unwrap_err().to_string();
        assert!(missing.contains("none.json5") && missing.contains("cannot be read"), "{missing}");
        std::fs::write(
            dir.join("open.json5"),
            "{ access_control: { enabled: true, default_permission: \"allow\" } }",
        )
        .unwrap();
        assert!(!load(&dir, "open.json5").unwrap().denies_by_default);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[cfg(unix)]
    #[test]
    fn a_dictionary_others_can_read_is_warned_about() {
        use std::os::unix::fs::PermissionsExt;
        let dir = temp_dir("modes");
        let users = dir.join("users.txt");
        std::fs::write(&users, "gcs:secret\n").unwrap();
        std::fs::write(
            dir.join("z.json5"),
            "{ transport: { auth: { usrpwd: { dictionary_file: \"users.txt\" } } } }",
        )
        .unwrap();
        std::fs::set_permissions(&users, std::fs::Permissions::from_mode(0o644)).unwrap();
        let warnings = load(&dir, "z.json5").unwrap().warnings;
        assert!(
            warnings.len() == 1 && warnings[0].contains("mode 644") && warnings[0].contains("users.txt"),
            "{warnings:?}"
        );
        std::fs::set_permissions(&users, std::fs::Permissions::from_mode(0o600)).unwrap();
        assert!(load(&dir, "z.json5").unwrap().warnings.is_empty());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
