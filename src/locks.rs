//! One vehicle, one process: exclusive locks on the run's instance and on every device its
//! drivers open.
//!
//! A second `kestrel run` on the same board would reset the IMU under the first and write
//! disarmed pulses to the same PWM channels, so each driver claims its device
//! ([`kestrel_proto::Setup::claim_device`]) before it opens it, and `kestrel run` claims its
//! instance (the config file and `--instance`, in this network namespace, where its UDP ports
//! live) before it builds anything. A claim that another process holds fails at start with
//! an error naming the holder's pid. The locks are `flock(2)` locks on files in [`lock_dir`],
//! each holding its owner's pid: the kernel drops them when the process ends, however it ends,
//! so a crashed run never leaves a stale lock behind.
//! Held by tests/process_instance_lock.rs and the unit tests below.

use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, Write};
use std::os::fd::AsRawFd;
use std::os::unix::fs::{OpenOptionsExt, PermissionsExt};
use std::path::{Path, PathBuf};

/// Why a lock could not be taken.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    #[error("{what} is in use by another kestrel process (pid {pid}; lock file {})", path.display())]
    Held { what: String, pid: String, path: PathBuf },
    #[error("cannot lock {what} ({}): {source}", path.display())]
    Io {
        what: String,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// A held lock; dropping it (or the process ending) releases it.
#[derive(Debug)]
pub struct Lock {
    _file: File,
    path: PathBuf,
}

impl Lock {
    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// Where lock files live: `$KESTREL_LOCK_DIR` if set, else `/run/lock/kestrel` (shared by every
/// user, as `/run/lock` is), else a folder of the temp dir.
pub fn lock_dir() -> PathBuf {
    if let Some(dir) = std::env::var_os("KESTREL_LOCK_DIR") {
        return PathBuf::from(dir);
    }
    let shared = Path::new("/run/lock/kestrel");
    if ensure_dir(shared).is_ok() {
        return shared.to_owned();
    }
    std::env::temp_dir().join("kestrel-locks")
}

/// Creates `dir` writable by everyone with the sticky bit (as `/run/lock` itself), so runs by
/// different users meet in the same folder.
fn ensure_dir(dir: &Path) -> std::io::Result<()> {
    if !dir.is_dir() {
        std::fs::create_dir_all(dir)?;
        std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o1777))?;
    }
    let probe = std::fs::metadata(dir)?;
    if probe.permissions().readonly() {
        return Err(std::io::Error::from(std::io::ErrorKind::PermissionDenied));
    }
    Ok(())
}

/// Takes the exclusive lock `name` in `dir` for `what` (for messages), or says who holds it.
pub fn acquire(dir: &Path, name: &str, what: &str) -> Result<Lock, LockError> {
    let path = dir.join(name);
    let io = |source| LockError::Io { what: what.to_owned(), path: path.clone(), source };
    ensure_dir(dir).or_else(|_| std::fs::create_dir_all(dir)).map_err(io)?;
    let mut file = OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .mode(0o666)
        .open(&path)
        .map_err(io)?;
    // SAFETY: flock on a descriptor this function owns; no memory is shared.
    if unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) } != 0 {
        let err = std::io::Error::last_os_error();
        if err.raw_os_error() != Some(libc::EWOULDBLOCK) {
            return Err(io(err));
        }
        let mut pid = String::new();
        let _ = file.read_to_string(&mut pid);
        let pid = pid.trim();
        let pid = if pid.is_empty() { "unknown".to_owned() } else { pid.to_owned() };
        return Err(LockError::Held { what: what.to_owned(), pid, path });
    }
    file.set_len(0).map_err(io)?;
    file.rewind().map_err(io)?;
    writeln!(file, "{}", std::process::id()).map_err(io)?;
    file.flush().map_err(io)?;
    Ok(Lock { _file: file, path })
}

/// The lock file's name for `device`: its path with `/` as `_`, so `/dev/spidev0.1` and
/// `/sys/class/pwm/pwmchip0` each have one.
pub fn device_lock_name(device: &Path) -> String {
    let flat: String = device
        .to_string_lossy()
        .trim_start_matches('/')
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() || c == '.' || c == '-' { c } else { '_' })
        .collect();
    format!("device-{flat}.lock")
}

/// Claims `device` for this process, held in `held`: the same device claimed twice by this
/// process is one claim (two actors on one I²C bus).
pub fn claim_device(held: &mut Vec<Lock>, device: &Path) -> Result<(), LockError> {
    // Through its symlinks (`/dev/serial/by-id/...`, `/dev/serial0`), so two names of one device
    // meet in one lock.
    let device = &device.canonicalize().unwrap_or_else(|_| device.to_owned());
    let name = device_lock_name(device);
    let dir = lock_dir();
    if held.iter().any(|l| l.path == dir.join(&name)) {
        return Ok(());
    }
    held.push(acquire(&dir, &name, &format!("device {}", device.display()))?);
    Ok(())
}

/// The lock for instance `instance` of the config at `config`: one per config file, instance
/// and network namespace (two namespaces have separate UDP ports, so the same config runs in
/// each without meeting).
pub fn claim_instance(config: &Path, instance: u8) -> Result<Lock, LockError> {
    let canonical = config.canonicalize().unwrap_or_else(|_| config.to_owned());
    let netns = std::fs::read_link("/proc/self/ns/net").map(|p| p.display().to_string()).unwrap_or_default();
    let key = format!("{}\0{netns}", canonical.display());
    let stem = canonical.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let name = format!("instance-{stem}-{instance}-{:016x}.lock", fnv1a(key.as_bytes()));
    acquire(&lock_dir(), &name, &format!("instance {instance} of {}", canonical.display()))
}

/// FNV-1a, 64 bits: a stable name for a path (std's hasher may change between releases).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, b| (h ^ u64::from(*b)).wrapping_mul(0x0000_0100_0000_01b3))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("kestrel-locks-test-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("scratch");
        dir
    }

    #[test]
    fn a_held_lock_refuses_a_second_holder_and_names_the_first_pid() {
        let dir = scratch("held");
        let first = acquire(&dir, "x.lock", "instance 0 of sim.toml").expect("first");
        // flock locks belong to the open file description: a second open in the same process
        // conflicts just as another process would.
        let err = acquire(&dir, "x.lock", "instance 0 of sim.toml").expect_err("second");
        let text = err.to_string();
        assert!(text.contains(&format!("pid {}", std::process::id())), "{text}");
        assert!(text.contains("instance 0 of sim.toml"), "{text}");
        drop(first);
        acquire(&dir, "x.lock", "instance 0 of sim.toml").expect("free again once dropped");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn device_names_are_flat_and_distinct() {
        assert_eq!(device_lock_name(Path::new("/dev/spidev0.1")), "device-dev_spidev0.1.lock");
        assert_ne!(
            device_lock_name(Path::new("/sys/class/pwm/pwmchip0")),
            device_lock_name(Path::new("/sys/class/pwm/pwmchip1"))
        );
    }

    #[test]
    fn fnv1a_matches_the_published_test_vector() {
        // FNV-1a 64 of "a" (the reference implementation's test suite).
        assert_eq!(fnv1a(b"a"), 0xaf63_dc4c_8601_ec8c);
    }
}
