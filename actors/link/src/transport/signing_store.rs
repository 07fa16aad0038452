//! The signing timestamp across restarts. A companion computer without a real-time clock boots
//! in 1970; without the stored value, frames captured before the reboot would be new streams
//! again. The MAVLink spec asks for the timestamp to be stored at least once a minute and at
//! shutdown; we store it every [`SAVE_PERIOD`] (ArduPilot's `save_signing_timestamp`) and when
//! the link stops, in one decimal line replaced atomically, and [`super::signing::Streams::new`]
//! restores it a minute ahead.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use tokio_util::sync::CancellationToken;

use super::param_writer::write_atomically;
use super::signing::{Streams, wall_timestamp};

/// How often the timestamp is stored while running (ArduPilot: 30 s).
pub const SAVE_PERIOD: Duration = Duration::from_secs(30);

/// Why the stored timestamp could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    #[error("signing timestamp file {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("signing timestamp file {path}: {text:?} is not a timestamp (10 µs units since 2015)")]
    Format { path: PathBuf, text: String },
}

/// The file of one vehicle's signing timestamp.
#[derive(Debug, Clone)]
pub struct TimestampFile {
    path: PathBuf,
}

impl TimestampFile {
    /// The file of system `system_id` in `dir` (one per system id, so each `--instance` of a
    /// config keeps its own).
    pub fn in_dir(dir: &Path, system_id: u8) -> TimestampFile {
        TimestampFile { path: dir.join(format!("signing_timestamp_sys{system_id}.txt")) }
    }

    /// Where it lives.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The stored timestamp; `None` when none was ever stored.
    pub fn load(&self) -> Result<Option<u64>, StoreError> {
        let text = match std::fs::read_to_string(&self.path) {
            Ok(text) => text,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(source) => return Err(StoreError::Io { path: self.path.clone(), source }),
        };
        let value = text.trim().parse::<u64>();
        value.map(Some).map_err(|_| StoreError::Format { path: self.path.clone(), text })
    }

    /// Stores `timestamp` (atomically: a crash leaves the old value or the new one).
    pub fn save(&self, timestamp: u64) -> Result<(), StoreError> {
        write_atomically(&self.path, &format!("{timestamp}\n"))
            .map_err(|source| StoreError::Io { path: self.path.clone(), source })
    }
}

/// Stores `streams`' timestamp every `period` ([`SAVE_PERIOD`]) when it moved, and once more
/// when `shutdown` is cancelled; the returned handle finishes after that last write.
pub fn spawn_saver(
    file: TimestampFile,
    streams: Arc<Streams>,
    stored: Option<u64>,
    period: Duration,
    shutdown: CancellationToken,
) -> tokio::task::JoinHandle<()> {
    tokio::spawn(async move {
        let mut last = stored;
        let mut every = tokio::time::interval(period);
        every.tick().await;
        loop {
            tokio::select! {
                _ = shutdown.cancelled() => break,
                _ = every.tick() => {}
            }
            streams.advance_to(wall_timestamp());
            let now = streams.timestamp();
            if last.is_some_and(|l| l >= now) {
                continue;
            }
            let f = file.clone();
            match tokio::task::spawn_blocking(move || f.save(now)).await {
                Ok(Ok(())) => last = Some(now),
                Ok(Err(error)) => tracing::error!(%error, "signing timestamp not stored"),
                Err(error) => tracing::error!(%error, "signing timestamp writer failed"),
            }
        }
        streams.advance_to(wall_timestamp());
        match file.save(streams.timestamp()) {
            Ok(()) => tracing::info!(path = %file.path().display(), "signing timestamp stored at shutdown"),
            Err(error) => tracing::error!(%error, "signing timestamp not stored at shutdown"),
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("kestrel-ts-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&d).expect("dir");
        d
    }

    #[test]
    fn a_stored_timestamp_loads_back_and_garbage_is_a_typed_error() {
        let d = dir("roundtrip");
        let file = TimestampFile::in_dir(&d, 3);
        assert!(file.path().ends_with("signing_timestamp_sys3.txt"));
        assert_eq!(file.load().expect("absent is fine"), None);
        file.save(123_456_789_012).expect("save");
        assert_eq!(file.load().expect("load"), Some(123_456_789_012));
        std::fs::write(file.path(), "soon\n").expect("write");
        assert!(matches!(file.load(), Err(StoreError::Format { text, .. }) if text == "soon\n"));
        std::fs::remove_dir_all(&d).ok();
    }

    #[tokio::test]
    async fn the_saver_stores_within_its_period_and_at_shutdown() {
        let d = dir("saver");
        let file = TimestampFile::in_dir(&d, 1);
        let streams = Arc::new(Streams::new(None, 0));
        let shutdown = CancellationToken::new();
        let period = Duration::from_millis(50);
        let saver = spawn_saver(file.clone(), Arc::clone(&streams), None, period, shutdown.clone());
        for _ in 0..100 {
            if file.load().ok().flatten().is_some() {
                break;
            }
            tokio::time::sleep(period).await;
        }
        let periodic = file.load().expect("load").expect("stored within one period");
        assert!(periodic >= wall_timestamp() - 100_000 * 5, "the wall clock moved it forward");
        streams.advance_to(periodic + 10 * super::super::signing::ONE_MINUTE);
        shutdown.cancel();
        saver.await.expect("saver");
        assert_eq!(file.load().expect("load"), Some(streams.timestamp()));
        std::fs::remove_dir_all(&d).ok();
    }
}
