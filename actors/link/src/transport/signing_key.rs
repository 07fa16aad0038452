//! Signing keys in files: 32 raw bytes or 64 hex digits, readable by the owner alone (a key
//! file that group or others may read is refused, as ssh refuses such a private key), and
//! replaceable at run time by SETUP_SIGNING (written atomically with mode 0600).

use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::sync::RwLock;

/// Why a key file was refused.
#[derive(Debug, thiserror::Error)]
pub enum KeyError {
    #[error("signing key {path}: {source}")]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(
        "signing key {path}: mode {mode:04o} lets group or others read it; `chmod 600 {path}` (as ssh asks of private keys)"
    )]
    Permissions { path: PathBuf, mode: u32 },
    #[error("signing key {path}: expected 32 raw bytes or 64 hex digits")]
    Format { path: PathBuf },
    #[error("signing key {path}: cannot write it: {source}")]
    Write {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// One endpoint's key, shared by every link of that endpoint (and by endpoints naming the same
/// file) so SETUP_SIGNING changes it for all of them at once.
#[derive(Debug)]
pub struct SigningKey {
    key: RwLock<[u8; 32]>,
    /// The file it came from and is written back to.
    path: PathBuf,
}

impl SigningKey {
    /// Reads the key at `path`, refusing a file group or others may read.
    pub fn load(path: &Path) -> Result<SigningKey, KeyError> {
        let read = |source| KeyError::Read { path: path.to_owned(), source };
        let mode = std::fs::metadata(path).map_err(read)?.permissions().mode();
        if mode & 0o077 != 0 {
            return Err(KeyError::Permissions { path: path.to_owned(), mode: mode & 0o7777 });
        }
        let bytes = std::fs::read(path).map_err(read)?;
        let key = parse_key(&bytes).ok_or_else(|| KeyError::Format { path: path.to_owned() })?;
        Ok(SigningKey { key: RwLock::new(key), path: path.to_owned() })
    }

    /// The key now.
    pub fn get(&self) -> [u8; 32] {
        *self.key.read().unwrap_or_else(|e| e.into_inner())
    }

    /// The file the key lives in.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes `key` to the file (64 hex digits, mode 0600, replaced atomically) and then uses
    /// it; on a write error the old key stays in force.
    pub fn install(&self, key: [u8; 32]) -> Result<(), KeyError> {
        write_key(&self.path, &key).map_err(|source| KeyError::Write { path: self.path.clone(), source })?;
        *self.key.write().unwrap_or_else(|e| e.into_inner()) = key;
        Ok(())
    }

    #[cfg(test)]
    pub(crate) fn for_tests(key: [u8; 32]) -> SigningKey {
        SigningKey { key: RwLock::new(key), path: PathBuf::from("/nonexistent/test.key") }
    }
}

fn write_key(path: &Path, key: &[u8; 32]) -> std::io::Result<()> {
    let text: String = key.iter().map(|b| format!("{b:02x}")).collect::<String>() + "\n";
    super::param_writer::write_atomically_as(path, &text, Some(0o600))
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

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("kestrel-key-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&d).expect("dir");
        d
    }

    fn write(path: &Path, text: &str, mode: u32) {
        std::fs::write(path, text).expect("write");
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode)).expect("chmod");
    }

    #[test]
    fn raw_and_hex_keys_parse_and_others_do_not() {
        assert_eq!(parse_key(&[5u8; 32]), Some([5u8; 32]));
        let hex = "0a".repeat(32) + "\n";
        assert_eq!(parse_key(hex.as_bytes()), Some([10u8; 32]));
        assert_eq!(parse_key(b"short"), None);
        assert_eq!(parse_key("zz".repeat(32).as_bytes()), None);
    }

    #[test]
    fn a_key_group_or_others_may_read_is_refused_naming_the_file_and_its_mode() {
        let d = dir("modes");
        let path = d.join("gcs.key");
        for mode in [0o644, 0o640, 0o604, 0o660] {
            write(&path, &"0a".repeat(32), mode);
            let err = SigningKey::load(&path).expect_err("readable by others");
            assert!(matches!(err, KeyError::Permissions { mode: m, .. } if m == mode), "{err}");
            let text = err.to_string();
            assert!(
                text.contains(&path.display().to_string()) && text.contains(&format!("{mode:04o}")),
                "{text}"
            );
        }
        for mode in [0o600, 0o400] {
            write(&path, &"0a".repeat(32), mode);
            assert_eq!(SigningKey::load(&path).expect("owner only").get(), [10; 32]);
        }
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn an_installed_key_is_in_force_and_reloads_from_an_owner_only_file() {
        let d = dir("install");
        let path = d.join("radio.key");
        write(&path, &"0a".repeat(32), 0o600);
        let key = SigningKey::load(&path).expect("load");
        key.install([0x5c; 32]).expect("install");
        assert_eq!(key.get(), [0x5c; 32]);
        let mode = std::fs::metadata(&path).expect("meta").permissions().mode() & 0o777;
        assert_eq!(mode, 0o600);
        assert_eq!(SigningKey::load(&path).expect("reload").get(), [0x5c; 32]);
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn a_failed_install_keeps_the_old_key() {
        let key = SigningKey::for_tests([1; 32]);
        assert!(matches!(key.install([2; 32]), Err(KeyError::Write { .. })));
        assert_eq!(key.get(), [1; 32]);
    }
}
