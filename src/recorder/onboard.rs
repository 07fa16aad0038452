//! Logs on the vehicle: every arming-to-disarming (or the whole run, with `log_disarmed`, as
//! ArduPilot's LOG_DISARMED=1) writes its own numbered MCAP log in the log directory, never
//! overwriting one; before each new log the oldest ones are removed until the directory is
//! within its size budget and file count (ArduPilot's LOG_MAX_FILES). The link serves the
//! directory to ground stations (`kestrel_link::services::{log_download, ftp}`).
//!
//! The segmenting runs on the recorder's writer thread ([`Segments`] is its sink), driven by the
//! recorded `vehicle_status` messages themselves: a log starts with the first status saying
//! armed and ends with the first saying disarmed, in the order the router recorded them, so the
//! same flight gives the same log whatever the scheduling.
//!
//! A write error ends that log (its file stays, incomplete), is logged and kept in
//! [`OnboardStatus`] for the status line; the next arming starts a new log. The flight goes on.
//!
//! Held by `recorder::onboard::tests`, `tests/gcs_log_download.rs` and `tests/gcs_mavsdk.rs` (the log of
//! a flight, downloaded, equals the file and starts armed and ends disarmed).

use std::fs::{File, OpenOptions};
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};

use kestrel_link::services::log_download::{LogDirectory, LogFile, log_file_name};
use mcap::records::MessageHeader;

use super::writer::{Sink, WriterFailure, close_mcap, mcap_writer};

/// The topic whose `armed` field starts and ends a log.
pub const STATUS_TOPIC: &str = "vehicle_status";

/// Where and how the vehicle keeps its logs (`[record]` `dir`, `log_disarmed`, `budget_mb`,
/// `max_files`).
#[derive(Clone, Debug, PartialEq)]
pub struct OnboardLog {
    pub dir: PathBuf,
    /// One log for the whole run, armed or not (ArduPilot's LOG_DISARMED=1).
    pub log_disarmed: bool,
    /// Most bytes the directory's logs may hold when a new log starts; the oldest go first.
    pub budget_bytes: u64,
    /// Most logs kept, the new one included (ArduPilot's LOG_MAX_FILES).
    pub max_files: usize,
}

/// What the onboard log is doing, shared with the status line.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OnboardStatus {
    /// The log being written.
    pub current: Option<PathBuf>,
    /// Logs started since the run began.
    pub started: u32,
    /// The last write, rotation or creation error, said in words.
    pub last_error: Option<String>,
}

/// The logs to remove, oldest first, so that `logs` (oldest first) leave room for one more log
/// within `max_files` and hold at most `budget_bytes`.
pub fn to_remove(logs: &[LogFile], budget_bytes: u64, max_files: usize) -> Vec<PathBuf> {
    let mut total: u64 = logs.iter().map(|l| l.size_bytes).sum();
    let mut count = logs.len();
    let mut out = Vec::new();
    for log in logs {
        if count < max_files.max(1) && total <= budget_bytes {
            break;
        }
        out.push(log.path.clone());
        total -= log.size_bytes;
        count -= 1;
    }
    out
}

/// The number the next log gets: one past the highest in the directory (1 in an empty one).
pub fn next_number(logs: &[LogFile]) -> u32 {
    logs.iter().map(|l| l.number).max().map_or(1, |n| n.saturating_add(1))
}

/// The writer thread's sink for onboard logs.
pub(super) struct Segments {
    config: OnboardLog,
    status: Arc<Mutex<OnboardStatus>>,
    /// Schemas and channels registered so far, written at the top of every new log.
    schemas: Vec<(u16, &'static str, Vec<u8>)>,
    channels: Vec<(u16, u16, String)>,
    /// The channel id of [`STATUS_TOPIC`], once registered.
    status_channel: Option<u16>,
    current: Option<(PathBuf, mcap::Writer<BufWriter<File>>)>,
}

/// The one field of a recorded `VehicleStatus` the segmenting reads.
#[derive(serde::Deserialize)]
struct Armed {
    armed: bool,
}

impl Segments {
    pub(super) fn new(config: OnboardLog, status: Arc<Mutex<OnboardStatus>>) -> Segments {
        let mut segments = Segments {
            config,
            status,
            schemas: Vec::new(),
            channels: Vec::new(),
            status_channel: None,
            current: None,
        };
        if segments.config.log_disarmed {
            segments.start();
        }
        segments
    }

    fn set_status(&self, f: impl FnOnce(&mut OnboardStatus)) {
        f(&mut self.status.lock().unwrap_or_else(PoisonError::into_inner));
    }

    fn failed(&self, what: &str, path: &Path, e: &dyn std::fmt::Display) {
        let text = format!("log {what} {}: {e}", path.display());
        tracing::error!("{text}");
        self.set_status(|s| s.last_error = Some(text));
    }

    /// Starts a new log: rotates, creates the next number (never an existing file) and writes
    /// every registration so far.
    fn start(&mut self) {
        let dir = LogDirectory::new(&self.config.dir);
        if let Err(e) = std::fs::create_dir_all(&self.config.dir) {
            return self.failed("directory", &self.config.dir.clone(), &e);
        }
        let logs = match dir.list() {
            Ok(logs) => logs,
            Err(e) => return self.failed("listing", &self.config.dir.clone(), &e),
        };
        for path in to_remove(&logs, self.config.budget_bytes, self.config.max_files) {
            match std::fs::remove_file(&path) {
                Ok(()) => tracing::info!(path = %path.display(), "old log removed (log budget)"),
                Err(e) if e.kind() == io::ErrorKind::NotFound => {}
                Err(e) => self.failed("rotation", &path, &e),
            }
        }
        // Another process may take a number between the listing and the create: try the next.
        let mut number = next_number(&logs);
        let (path, file) = loop {
            let path = self.config.dir.join(log_file_name(number));
            match OpenOptions::new().write(true).create_new(true).open(&path) {
                Ok(file) => break (path, file),
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists && number < u32::MAX => number += 1,
                Err(e) => return self.failed("creation", &path, &e),
            }
        };
        let mut writer = match mcap_writer(file) {
            Ok(w) => w,
            Err(e) => return self.failed("creation", &path, &e),
        };
        let replay = self
            .schemas
            .iter()
            .try_for_each(|(id, name, data)| {
                writer.add_schema_with_id(*id, name, super::format::SCHEMA_ENCODING, data).map(drop)
            })
            .and_then(|()| {
                self.channels.iter().try_for_each(|(id, schema_id, topic)| {
                    writer
                        .add_channel_with_id(
                            *id,
                            *schema_id,
                            topic,
                            super::format::MESSAGE_ENCODING,
                            &Default::default(),
                        )
                        .map(drop)
                })
            });
        if let Err(e) = replay {
            return self.failed("write", &path, &e);
        }
        tracing::info!(path = %path.display(), "log started");
        self.set_status(|s| {
            s.current = Some(path.clone());
            s.started += 1;
        });
        self.current = Some((path, writer));
    }

    /// Closes the current log (summary, sync).
    fn stop(&mut self) -> Option<u64> {
        let (path, writer) = self.current.take()?;
        self.set_status(|s| s.current = None);
        match close_mcap(writer) {
            Ok(size) => {
                tracing::info!(path = %path.display(), size_bytes = size, "log closed");
                Some(size)
            }
            Err(WriterFailure::Mcap(e)) => {
                self.failed("close", &path, &e);
                None
            }
            Err(WriterFailure::Io(e)) => {
                self.failed("close", &path, &e);
                None
            }
        }
    }

    /// Runs `f` on the open log; an error ends the log.
    fn with_log(
        &mut self,
        f: impl FnOnce(&mut mcap::Writer<BufWriter<File>>) -> Result<(), mcap::McapError>,
    ) -> bool {
        let Some((path, writer)) = self.current.as_mut() else { return false };
        match f(writer) {
            Ok(()) => true,
            Err(e) => {
                let path = path.clone();
                // The file stays as far as it was written; a new arming starts a new one.
                self.current = None;
                self.set_status(|s| s.current = None);
                self.failed("write", &path, &e);
                false
            }
        }
    }
}

impl Sink for Segments {
    fn schema(&mut self, id: u16, name: &'static str, data: &[u8]) -> Result<(), mcap::McapError> {
        self.schemas.push((id, name, data.to_vec()));
        self.with_log(|w| w.add_schema_with_id(id, name, super::format::SCHEMA_ENCODING, data).map(drop));
        Ok(())
    }

    fn channel(&mut self, id: u16, schema_id: u16, topic: &str) -> Result<(), mcap::McapError> {
        if topic == STATUS_TOPIC {
            self.status_channel = Some(id);
        }
        self.channels.push((id, schema_id, topic.to_owned()));
        self.with_log(|w| {
            w.add_channel_with_id(id, schema_id, topic, super::format::MESSAGE_ENCODING, &Default::default())
                .map(drop)
        });
        Ok(())
    }

    fn message(&mut self, header: &MessageHeader, data: &[u8]) -> Result<bool, mcap::McapError> {
        let armed = (!self.config.log_disarmed && self.status_channel == Some(header.channel_id))
            .then(|| serde_json::from_slice::<Armed>(data).ok().map(|a| a.armed))
            .flatten();
        if armed == Some(true) && self.current.is_none() {
            self.start();
        }
        let written = self.with_log(|w| w.write_to_known_channel(header, data));
        if armed == Some(false) && self.current.is_some() {
            self.stop();
        }
        Ok(written)
    }

    fn close(mut self: Box<Self>) -> Result<u64, WriterFailure> {
        Ok(self.stop().unwrap_or(0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recorder::{LogReader, Recorder};
    use kestrel_proto::Time;
    use kestrel_proto::messages::{FlightMode, LandedState, VehicleStatus};
    use kestrel_proto::testing::vehicle_status;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("kestrel-onboard-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    /// Records `armed` states (one status a second) into onboard logs in `dir`; the files made.
    fn fly(dir: &Path, log_disarmed: bool, budget_bytes: u64, armed: &[bool]) -> Vec<LogFile> {
        let config = OnboardLog { dir: dir.to_path_buf(), log_disarmed, budget_bytes, max_files: 10 };
        let (recorder, status) = Recorder::onboard(config).expect("onboard recorder");
        let channel = recorder.channel::<VehicleStatus>(STATUS_TOPIC).expect("channel");
        for (i, &a) in armed.iter().enumerate() {
            let t = Time::from_micros(i as u64 * 1_000_000);
            channel.record(t, &vehicle_status(t, a, FlightMode::Guided, LandedState::OnGround));
        }
        recorder.finish().expect("finish");
        assert_eq!(status.lock().expect("status").last_error, None);
        LogDirectory::new(dir).list().expect("list")
    }

    fn armed_in(log: &LogFile) -> Vec<bool> {
        let reader = LogReader::open(&log.path).expect("a whole MCAP log");
        reader
            .read::<VehicleStatus>(STATUS_TOPIC)
            .expect("statuses")
            .iter()
            .map(|r| r.message.armed)
            .collect()
    }

    #[test]
    fn each_arming_to_disarming_is_its_own_numbered_log_and_none_is_overwritten() {
        let dir = scratch("flights");
        let logs = fly(&dir, false, u64::MAX, &[false, true, true, false, false, true, false]);
        let numbers: Vec<u32> = logs.iter().map(|l| l.number).collect();
        assert_eq!(numbers, [1, 2]);
        assert_eq!(armed_in(&logs[0]), [true, true, false]);
        assert_eq!(armed_in(&logs[1]), [true, false]);
        // A second run numbers on; a flight cut short by the end of the run is closed whole.
        let more = fly(&dir, false, u64::MAX, &[true, true]);
        assert_eq!(more.iter().map(|l| l.number).collect::<Vec<_>>(), [1, 2, 3]);
        assert_eq!(armed_in(&more[2]), [true, true]);
        assert_eq!(armed_in(&more[0]), [true, true, false], "log 1 untouched");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn log_disarmed_makes_one_log_of_the_run_and_the_budget_removes_the_oldest() {
        let dir = scratch("disarmed");
        let logs = fly(&dir, true, u64::MAX, &[false, true, false, true, false]);
        assert_eq!(logs.len(), 1);
        assert_eq!(armed_in(&logs[0]), [false, true, false, true, false]);
        // A budget smaller than one log: each new log starts in an emptied directory.
        let logs = fly(&dir, false, 1, &[true, false, true, false]);
        assert_eq!(logs.iter().map(|l| l.number).collect::<Vec<_>>(), [3]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_log_directory_that_cannot_be_made_is_an_error_naming_it() {
        let file = scratch("not-a-dir");
        std::fs::write(&file, "a file").expect("write");
        let config =
            OnboardLog { dir: file.join("logs"), log_disarmed: false, budget_bytes: 1, max_files: 2 };
        let error = Recorder::onboard(config).err().expect("refused").to_string();
        assert!(error.contains("not-a-dir"), "{error}");
        let _ = std::fs::remove_file(&file);
    }

    fn log(number: u32, size_bytes: u64) -> LogFile {
        LogFile { number, path: PathBuf::from(log_file_name(number)), size_bytes, time_utc: 0 }
    }

    #[test]
    fn the_oldest_logs_go_until_the_rest_fit_the_budget_and_leave_room_for_one_more() {
        let logs = [log(3, 40), log(4, 30), log(9, 20)];
        let names = |v: Vec<PathBuf>| v.into_iter().map(|p| p.display().to_string()).collect::<Vec<_>>();
        assert!(to_remove(&logs, 90, 4).is_empty(), "within both");
        assert_eq!(names(to_remove(&logs, 89, 4)), ["00000003.mcap"]);
        assert_eq!(names(to_remove(&logs, 20, 4)), ["00000003.mcap", "00000004.mcap"]);
        assert_eq!(names(to_remove(&logs, 0, 4)).len(), 3, "a zero budget keeps none");
        assert_eq!(names(to_remove(&logs, 1000, 3)), ["00000003.mcap"], "room for the new one");
        assert_eq!(next_number(&logs), 10);
        assert_eq!(next_number(&[]), 1);
    }

    proptest::proptest! {
        #[test]
        fn after_rotation_the_kept_logs_are_the_newest_and_fit(
            sizes in proptest::collection::vec(0u64..1000, 0..20),
            budget in 0u64..5000,
            max_files in 1usize..10,
        ) {
            let logs: Vec<LogFile> = sizes.iter().enumerate().map(|(i, &s)| log(i as u32 + 1, s)).collect();
            let removed = to_remove(&logs, budget, max_files);
            let kept = &logs[removed.len()..];
            proptest::prop_assert!(kept.len() < max_files);
            proptest::prop_assert!(kept.iter().map(|l| l.size_bytes).sum::<u64>() <= budget);
            // Minimal: keeping one more (the newest removed) would break a limit.
            if let Some(last_removed) = removed.len().checked_sub(1) {
                let one_more = &logs[last_removed..];
                proptest::prop_assert!(
                    one_more.len() >= max_files || one_more.iter().map(|l| l.size_bytes).sum::<u64>() > budget
                );
            }
        }
    }
}
