//! Parameter persistence off the receive path. A PARAM_SET is answered at once; the file write
//! (write + fsync + rename + fsync of the directory: tens of milliseconds on an SD card) runs on
//! a thread of its own. Sets that arrive while a write is in progress collapse into one pending
//! text, so a burst from a ground station costs at most one more write and the last value wins.
//!
//! Each text carries a tag (the parameter table's batch number); a writer built with a report
//! hands the outcome of every write, tagged, back on its own thread, and takes from the report an
//! optional text to write next (`transport::param_persistence` wires it to the table).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;

/// What the writer has done so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WriterStats {
    /// Texts handed to [`ParamWriter::submit`].
    pub submitted: u64,
    /// Texts replaced by a newer one before they were written.
    pub coalesced: u64,
    /// Completed writes.
    pub written: u64,
    /// Writes that failed (logged; the next set tries again).
    pub failed: u64,
}

/// What a writer hands back after a write: the tag of the text written and how it went; the
/// answer is a `(tag, text)` to write next (a text that replaces any pending one), if any.
pub type Report = Box<dyn FnMut(u64, &std::io::Result<()>) -> Option<(u64, String)> + Send>;

#[derive(Default)]
struct Slot {
    /// The newest text not yet written, with its tag.
    pending: Option<(u64, String)>,
    /// Set by [`ParamWriter::finish`]: write what is pending, then stop.
    closing: bool,
    stats: WriterStats,
}

struct Inner {
    slot: Mutex<Slot>,
    /// Wakes the writer thread when a text is pending or the writer is closing.
    wake: Condvar,
}

impl Inner {
    fn slot(&self) -> MutexGuard<'_, Slot> {
        self.slot.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// A persistence thread fed with the latest parameter file text.
pub struct ParamWriter {
    inner: Arc<Inner>,
    thread: Mutex<Option<JoinHandle<()>>>,
}

impl ParamWriter {
    /// A writer that replaces `path` atomically (see [`write_atomically`]).
    pub fn to_file(path: PathBuf) -> std::io::Result<ParamWriter> {
        ParamWriter::spawn(file_writer(path))
    }

    /// A writer that hands every (coalesced) text to `write` on its own thread.
    pub fn spawn<F>(write: F) -> std::io::Result<ParamWriter>
    where
        F: FnMut(&str) -> std::io::Result<()> + Send + 'static,
    {
        ParamWriter::spawn_reporting(write, Box::new(|_, _| None))
    }

    /// [`ParamWriter::spawn`], handing the outcome of each write to `report` on the writer's
    /// thread (see [`Report`]).
    pub fn spawn_reporting<F>(mut write: F, mut report: Report) -> std::io::Result<ParamWriter>
    where
        F: FnMut(&str) -> std::io::Result<()> + Send + 'static,
    {
        let inner = Arc::new(Inner { slot: Mutex::new(Slot::default()), wake: Condvar::new() });
        let worker = Arc::clone(&inner);
        let thread = std::thread::Builder::new().name("kestrel-params".into()).spawn(move || {
            loop {
                let (tag, text) = {
                    let mut slot = worker.slot();
                    while slot.pending.is_none() && !slot.closing {
                        slot = worker.wake.wait(slot).unwrap_or_else(|e| e.into_inner());
                    }
                    match slot.pending.take() {
                        Some(pending) => pending,
                        None => return,
                    }
                };
                let result = write(&text);
                {
                    let mut slot = worker.slot();
                    if result.is_ok() {
                        slot.stats.written += 1;
                    } else {
                        slot.stats.failed += 1;
                    }
                }
                // Outside the slot's lock: the report takes the link's hub, whose holders submit.
                if let Some(next) = report(tag, &result) {
                    let mut slot = worker.slot();
                    slot.stats.submitted += 1;
                    if slot.pending.replace(next).is_some() {
                        slot.stats.coalesced += 1;
                    }
                }
            }
        })?;
        Ok(ParamWriter { inner, thread: Mutex::new(Some(thread)) })
    }

    /// Queues `text` to be written, replacing any text not yet written. Never waits for a
    /// write.
    pub fn submit(&self, text: String) {
        self.submit_tagged(0, text);
    }

    /// [`ParamWriter::submit`] with the tag its report will carry.
    pub fn submit_tagged(&self, tag: u64, text: String) {
        let mut slot = self.inner.slot();
        slot.stats.submitted += 1;
        if slot.pending.replace((tag, text)).is_some() {
            slot.stats.coalesced += 1;
        }
        drop(slot);
        self.inner.wake.notify_one();
    }

    /// Counters so far.
    pub fn stats(&self) -> WriterStats {
        self.inner.slot().stats
    }

    /// Writes what is pending and stops the thread, waiting for it (blocking: call from the
    /// blocking pool). Later submits are kept in memory only.
    pub fn finish(&self) {
        self.inner.slot().closing = true;
        self.inner.wake.notify_one();
        let thread = self.thread.lock().unwrap_or_else(|e| e.into_inner()).take();
        if let Some(thread) = thread
            && thread.join().is_err()
        {
            tracing::error!("the parameter writer thread panicked");
        }
    }
}

impl Drop for ParamWriter {
    /// An unfinished writer still writes what is pending, then its thread ends by itself.
    fn drop(&mut self) {
        self.inner.slot().closing = true;
        self.inner.wake.notify_one();
    }
}

/// Writes each text to `path` atomically, logging a failure with the file's name.
pub fn file_writer(path: PathBuf) -> impl FnMut(&str) -> std::io::Result<()> + Send + 'static {
    let name = path.display().to_string();
    move |text| {
        write_atomically(&path, text).inspect_err(|e| {
            tracing::error!(path = %name, error = %e, "cannot persist parameters");
        })
    }
}

/// Replaces `path` with `text` so that a power cut leaves the old or the new file, never a mix:
/// write a temporary file next to it, flush it to disk, rename it over, and flush the directory
/// so the rename itself is on disk.
pub fn write_atomically(path: &Path, text: &str) -> std::io::Result<()> {
    write_atomically_as(path, text, None)
}

/// [`write_atomically`], the new file given permission bits `mode` when one is named (a secret
/// is written owner-only from its first byte: the temporary file is created, or reset, so).
pub fn write_atomically_as(path: &Path, text: &str, mode: Option<u32>) -> std::io::Result<()> {
    use std::os::unix::fs::{OpenOptionsExt, PermissionsExt};
    let tmp = path.with_extension("tmp");
    let mut options = std::fs::OpenOptions::new();
    options.write(true).create(true).truncate(true);
    if let Some(mode) = mode {
        options.mode(mode);
    }
    let mut f = options.open(&tmp)?;
    if let Some(mode) = mode {
        // `mode` applies only to a file the open creates: a stale temporary file keeps its own.
        f.set_permissions(std::fs::Permissions::from_mode(mode))?;
    }
    f.write_all(text.as_bytes())?;
    f.sync_all()?;
    std::fs::rename(&tmp, path)?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    std::fs::File::open(dir)?.sync_all()
}

#[cfg(test)]
mod tests {
    use std::sync::mpsc;
    use std::time::{Duration, Instant};

    use super::*;

    #[test]
    fn a_burst_during_a_slow_write_collapses_to_the_last_text_and_never_waits() {
        let (gate_tx, gate_rx) = mpsc::channel::<()>();
        let (seen_tx, seen_rx) = mpsc::channel::<String>();
        let writer = ParamWriter::spawn(move |text| {
            seen_tx.send(text.to_owned()).ok();
            // Each write is held until the test releases it: a disk that stalls.
            gate_rx.recv().ok();
            Ok(())
        })
        .expect("thread");
        writer.submit("P=0\n".into());
        assert_eq!(seen_rx.recv_timeout(Duration::from_secs(5)).expect("first write started"), "P=0\n");
        let started = Instant::now();
        for i in 1..=1000 {
            writer.submit(format!("P={i}\n"));
        }
        let burst = started.elapsed();
        assert!(burst < Duration::from_millis(500), "submits waited for the stalled write: {burst:?}");
        gate_tx.send(()).expect("release the first write");
        gate_tx.send(()).expect("release the second write");
        writer.finish();
        let later: Vec<String> = seen_rx.try_iter().collect();
        assert_eq!(later, ["P=1000\n"]);
        assert_eq!(writer.stats(), WriterStats { submitted: 1001, coalesced: 999, written: 2, failed: 0 });
    }

    #[test]
    fn failed_writes_are_counted_and_the_next_text_is_still_written() {
        let (seen_tx, seen_rx) = mpsc::channel::<String>();
        let writer = ParamWriter::spawn(move |text| {
            seen_tx.send(text.to_owned()).ok();
            if text.starts_with("bad") { Err(std::io::Error::other("disk full")) } else { Ok(()) }
        })
        .expect("thread");
        writer.submit("bad\n".into());
        assert_eq!(seen_rx.recv_timeout(Duration::from_secs(5)).expect("written"), "bad\n");
        writer.submit("good\n".into());
        writer.finish();
        assert_eq!(seen_rx.try_iter().collect::<Vec<_>>(), ["good\n"]);
        let stats = writer.stats();
        assert_eq!((stats.written, stats.failed), (1, 1), "{stats:?}");
    }

    #[test]
    fn the_file_holds_the_last_text_and_no_temporary_is_left() {
        let dir = std::env::temp_dir().join(format!("kestrel-param-writer-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("params.txt");
        let writer = ParamWriter::to_file(path.clone()).expect("thread");
        for i in 0..200 {
            writer.submit(format!("RTL_ALT_M={i}\n"));
        }
        writer.finish();
        assert_eq!(std::fs::read_to_string(&path).expect("written"), "RTL_ALT_M=199\n");
        assert!(!path.with_extension("tmp").exists());
        std::fs::remove_dir_all(&dir).ok();
    }
}
