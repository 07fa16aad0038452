//! Log download (mavlink.io "Log" messages): LOG_REQUEST_LIST → LOG_ENTRY, LOG_REQUEST_DATA →
//! LOG_DATA, LOG_REQUEST_END, LOG_ERASE, answered as ArduCopter's `AP_Logger` answers them, over
//! the numbered MCAP logs of the vehicle's log directory ([`LogDirectory`]).
//!
//! What ArduCopter does, and so do we:
//! * Armed, every log message is ignored; the first one after arming gets one STATUSTEXT
//!   "Disarm for log download" (a download must not compete with a flight for the link).
//! * Log ids are 1..=N, oldest first. A list of an empty directory is one LOG_ENTRY with id 0,
//!   `num_logs` 0. `start` below 1 becomes 1 and `end` past the last log the last log;
//!   `last_log_num` is that clamped end. `time_utc` is the file's modification time (s).
//! * LOG_DATA carries up to 90 bytes at `ofs`; a chunk shorter than 90 bytes (a zero-length one
//!   when the request starts at or past the end) ends the transfer. A request for an unknown id
//!   cancels the transfer silently; one arriving while a transfer runs is dropped, as ArduPilot
//!   drops MAVProxy's streamed gap re-requests until the current one has ended.
//! * LOG_ERASE removes every log and is not answered; LOG_REQUEST_END stops sending.
//!
//! Unlike ArduPilot, a read error is said as a STATUSTEXT (the transfer then ends as at the end
//! of the file) rather than only ending the transfer.
//!
//! Held by the tests in this file, `tests/gcs_log_download.rs` (pymavlink, against ArduCopter too)
//! and `tests/gcs_mavsdk.rs` (MAVSDK's LogFiles on its defaults).

use std::fs::File;
use std::io;
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};
use std::time::UNIX_EPOCH;

use kestrel_proto::Time;
use mavlink::dialects::ardupilotmega::{LOG_DATA_DATA, LOG_ENTRY_DATA, MavMessage, MavSeverity};

use super::events::statustext;
use super::{Outputs, Sender, Service};

/// Bytes of log in one LOG_DATA (the message's `data` field).
pub const LOG_DATA_BYTES: usize = 90;

/// LOG_DATA sent per scheduler tick (50 Hz): 40 a tick is ArduPilot SITL's own number per
/// logger pass, 2000 messages (180 kB) a second, which a ground station's socket buffer takes.
pub const LOG_DATA_PER_TICK: usize = 40;

/// The extension of the vehicle's logs; the name is the log number in eight digits, as
/// ArduPilot names `00000001.BIN`.
pub const LOG_EXTENSION: &str = "mcap";

/// The file name of log `number`.
pub fn log_file_name(number: u32) -> String {
    format!("{number:08}.{LOG_EXTENSION}")
}

/// The number of a log file name made by [`log_file_name`]; `None` for any other name.
pub fn log_number(name: &str) -> Option<u32> {
    let stem = name.strip_suffix(LOG_EXTENSION)?.strip_suffix('.')?;
    (stem.len() == 8 && stem.bytes().all(|b| b.is_ascii_digit())).then(|| stem.parse().ok())?
}

/// One log of the directory.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LogFile {
    pub number: u32,
    pub path: PathBuf,
    pub size_bytes: u64,
    /// Modification time, seconds since 1970 (0 when the file system cannot say).
    pub time_utc: u32,
}

/// The directory the vehicle's numbered logs are written to and served from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LogDirectory {
    dir: PathBuf,
}

impl LogDirectory {
    pub fn new(dir: impl Into<PathBuf>) -> LogDirectory {
        LogDirectory { dir: dir.into() }
    }

    pub fn path(&self) -> &Path {
        &self.dir
    }

    /// The logs, oldest (lowest number) first; an absent directory holds none. Other files are
    /// ignored.
    pub fn list(&self) -> io::Result<Vec<LogFile>> {
        let entries = match std::fs::read_dir(&self.dir) {
            Ok(entries) => entries,
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(Vec::new()),
            Err(e) => return Err(e),
        };
        let mut logs = Vec::new();
        for entry in entries {
            let entry = entry?;
            let Some(number) = entry.file_name().to_str().and_then(log_number) else { continue };
            let meta = match entry.metadata() {
                Ok(meta) if meta.is_file() => meta,
                // Removed between the listing and the stat (rotation, an erase): not a log now.
                Err(e) if e.kind() == io::ErrorKind::NotFound => continue,
                Err(e) => return Err(e),
                Ok(_) => continue,
            };
            let time_utc = meta
                .modified()
                .ok()
                .and_then(|t| t.duration_since(UNIX_EPOCH).ok())
                .map_or(0, |d| u32::try_from(d.as_secs()).unwrap_or(u32::MAX));
            logs.push(LogFile { number, path: entry.path(), size_bytes: meta.len(), time_utc });
        }
        logs.sort_by_key(|l| l.number);
        Ok(logs)
    }
}

/// A LOG_REQUEST_DATA being answered.
#[derive(Debug)]
struct Transfer {
    id: u16,
    file: File,
    /// Next byte to send.
    offset: u32,
    /// Bytes still asked for (clamped to the file's size at the request).
    remaining: u32,
}

/// The log-download service.
#[derive(Debug)]
pub struct LogDownload {
    /// `None`: the vehicle keeps no logs; every list is empty.
    dir: Option<LogDirectory>,
    armed: bool,
    /// "Disarm for log download" was said since the last disarmed request.
    warned_armed: bool,
    sending: Option<Transfer>,
}

impl LogDownload {
    pub fn new(dir: Option<LogDirectory>) -> LogDownload {
        LogDownload { dir, armed: false, warned_armed: false, sending: None }
    }

    /// The commander's armed state: armed, requests are refused and a transfer pauses.
    pub fn set_armed(&mut self, armed: bool) {
        self.armed = armed;
    }

    fn logs(&self) -> io::Result<Vec<LogFile>> {
        self.dir.as_ref().map_or(Ok(Vec::new()), LogDirectory::list)
    }

    fn list(&mut self, start: u16, end: u16) -> Outputs {
        let logs = match self.logs() {
            Ok(logs) => logs,
            Err(e) => return self.failed("list", &e),
        };
        let num_logs = u16::try_from(logs.len()).unwrap_or(u16::MAX);
        let entry = |id: u16, last: u16| {
            let log = usize::from(id).checked_sub(1).and_then(|i| logs.get(i));
            MavMessage::LOG_ENTRY(LOG_ENTRY_DATA {
                time_utc: log.map_or(0, |l| l.time_utc),
                size: log.map_or(0, |l| u32::try_from(l.size_bytes).unwrap_or(u32::MAX)),
                id,
                num_logs,
                last_log_num: last,
            })
        };
        if num_logs == 0 {
            return Outputs::send(entry(0, 0));
        }
        let first = start.max(1);
        let last = end.min(num_logs);
        // ArduPilot sends the first entry even when start > end; so do we.
        let ids = if first <= last { first..=last } else { first..=first };
        Outputs { mav: ids.map(|id| entry(id, last)).collect(), graph: Vec::new() }
    }

    fn request_data(&mut self, id: u16, ofs: u32, count: u32) -> Outputs {
        if self.sending.is_some() {
            return Outputs::none();
        }
        let logs = match self.logs() {
            Ok(logs) => logs,
            Err(e) => return self.failed("list", &e),
        };
        let Some(log) = usize::from(id).checked_sub(1).and_then(|i| logs.get(i)) else {
            return Outputs::none();
        };
        let file = match File::open(&log.path) {
            Ok(file) => file,
            Err(e) => return self.failed(&log.path.display().to_string(), &e),
        };
        let size = u32::try_from(log.size_bytes).unwrap_or(u32::MAX);
        let remaining = size.saturating_sub(ofs).min(count);
        self.sending = Some(Transfer { id, file, offset: ofs, remaining });
        self.send_data()
    }

    /// Up to [`LOG_DATA_PER_TICK`] chunks of the running transfer.
    fn send_data(&mut self) -> Outputs {
        let mut out = Outputs::none();
        if self.armed {
            return out;
        }
        for _ in 0..LOG_DATA_PER_TICK {
            let Some(t) = self.sending.as_mut() else { break };
            let mut data = [0u8; LOG_DATA_BYTES];
            let want = (t.remaining as usize).min(LOG_DATA_BYTES);
            let read = match read_fully(&t.file, &mut data[..want], u64::from(t.offset)) {
                Ok(n) => n,
                Err(e) => {
                    out.mav.push(statustext(
                        MavSeverity::MAV_SEVERITY_WARNING,
                        &format!("Log {} read failed: {e}", t.id),
                    ));
                    0
                }
            };
            // `read` is at most 90.
            let count = read as u8;
            out.mav.push(MavMessage::LOG_DATA(LOG_DATA_DATA { ofs: t.offset, id: t.id, count, data }));
            t.offset = t.offset.saturating_add(u32::from(count));
            t.remaining = t.remaining.saturating_sub(u32::from(count));
            if read < LOG_DATA_BYTES || t.remaining == 0 {
                self.sending = None;
            }
        }
        out
    }

    fn erase(&mut self) -> Outputs {
        self.sending = None;
        let logs = match self.logs() {
            Ok(logs) => logs,
            Err(e) => return self.failed("list", &e),
        };
        let mut out = Outputs::none();
        for log in logs {
            match std::fs::remove_file(&log.path) {
                Ok(()) => {}
                Err(e) if e.kind() == io::ErrorKind::NotFound => {}
                Err(e) => out.extend(self.failed(&log.path.display().to_string(), &e)),
            }
        }
        out
    }

    fn failed(&self, what: &str, e: &io::Error) -> Outputs {
        tracing::warn!("log download: {what}: {e}");
        Outputs::send(statustext(MavSeverity::MAV_SEVERITY_WARNING, &format!("Log {what} failed: {e}")))
    }
}

/// Reads up to `buf.len()` bytes at `offset`, fewer only at the end of the file.
fn read_fully(file: &File, buf: &mut [u8], offset: u64) -> io::Result<usize> {
    let mut done = 0;
    while done < buf.len() {
        match file.read_at(&mut buf[done..], offset + done as u64) {
            Ok(0) => break,
            Ok(n) => done += n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(done)
}

impl Service for LogDownload {
    fn on_message(&mut self, _from: Sender, msg: &MavMessage, _now: Time) -> Option<Outputs> {
        let is_log = matches!(
            msg,
            MavMessage::LOG_REQUEST_LIST(_)
                | MavMessage::LOG_REQUEST_DATA(_)
                | MavMessage::LOG_REQUEST_END(_)
                | MavMessage::LOG_ERASE(_)
        );
        if !is_log {
            return None;
        }
        if self.armed {
            if std::mem::replace(&mut self.warned_armed, true) {
                return Some(Outputs::none());
            }
            return Some(Outputs::send(statustext(
                MavSeverity::MAV_SEVERITY_ERROR,
                "Disarm for log download",
            )));
        }
        self.warned_armed = false;
        Some(match msg {
            MavMessage::LOG_REQUEST_LIST(m) => {
                if self.sending.is_some() {
                    Outputs::send(statustext(MavSeverity::MAV_SEVERITY_INFO, "Log download in progress"))
                } else {
                    self.list(m.start, m.end)
                }
            }
            MavMessage::LOG_REQUEST_DATA(m) => self.request_data(m.id, m.ofs, m.count),
            MavMessage::LOG_REQUEST_END(_) => {
                self.sending = None;
                Outputs::none()
            }
            _ => self.erase(),
        })
    }

    fn on_tick(&mut self, _now: Time) -> Outputs {
        self.send_data()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mavlink::dialects::ardupilotmega::{
        LOG_ERASE_DATA, LOG_REQUEST_DATA_DATA, LOG_REQUEST_END_DATA, LOG_REQUEST_LIST_DATA,
    };

    const GCS: Sender = Sender { system_id: 255, component_id: 190 };

    /// A scratch directory removed when dropped.
    pub(crate) struct TestDir(PathBuf);

    impl TestDir {
        pub(crate) fn new(name: &str) -> TestDir {
            let dir = std::env::temp_dir().join(format!("kestrel-link-{name}-{}", std::process::id()));
            let _ = std::fs::remove_dir_all(&dir);
            std::fs::create_dir_all(&dir).expect("scratch dir");
            TestDir(dir)
        }

        pub(crate) fn path(&self) -> &Path {
            &self.0
        }
    }

    impl Drop for TestDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    fn dir_with(sizes: &[(u32, usize)]) -> (TestDir, LogDirectory) {
        static NEXT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let tmp = TestDir::new(&format!("logs-{n}"));
        for &(number, size) in sizes {
            let bytes: Vec<u8> = (0..size).map(|i| (i * 7 + number as usize) as u8).collect();
            std::fs::write(tmp.path().join(log_file_name(number)), bytes).expect("write");
        }
        std::fs::write(tmp.path().join("notes.txt"), "not a log").expect("write");
        let dir = LogDirectory::new(tmp.path());
        (tmp, dir)
    }

    fn list(s: &mut LogDownload, start: u16, end: u16) -> Vec<LOG_ENTRY_DATA> {
        let msg = MavMessage::LOG_REQUEST_LIST(LOG_REQUEST_LIST_DATA {
            start,
            end,
            target_system: 1,
            target_component: 1,
        });
        let out = s.on_message(GCS, &msg, Time::ZERO).expect("a log message");
        out.mav
            .into_iter()
            .map(|m| match m {
                MavMessage::LOG_ENTRY(e) => e,
                other => panic!("not a LOG_ENTRY: {other:?}"),
            })
            .collect()
    }

    fn download(s: &mut LogDownload, id: u16, ofs: u32, count: u32) -> Vec<LOG_DATA_DATA> {
        let msg = MavMessage::LOG_REQUEST_DATA(LOG_REQUEST_DATA_DATA {
            ofs,
            count,
            id,
            target_system: 1,
            target_component: 1,
        });
        let mut mav = s.on_message(GCS, &msg, Time::ZERO).expect("a log message").mav;
        for _ in 0..1000 {
            if s.sending.is_none() {
                break;
            }
            mav.extend(s.on_tick(Time::ZERO).mav);
        }
        mav.into_iter()
            .map(|m| match m {
                MavMessage::LOG_DATA(d) => d,
                other => panic!("not LOG_DATA: {other:?}"),
            })
            .collect()
    }

    #[test]
    fn log_names_are_eight_digit_numbers_and_nothing_else_is_a_log() {
        assert_eq!(log_file_name(7), "00000007.mcap");
        assert_eq!(log_number("00000007.mcap"), Some(7));
        for other in ["7.mcap", "0000007a.mcap", "00000007.bin", "00000007mcap", "000000007.mcap"] {
            assert_eq!(log_number(other), None, "{other}");
        }
    }

    #[test]
    fn a_list_gives_ids_oldest_first_with_sizes_and_clamps_its_range_as_ardupilot() {
        let (_tmp, dir) = dir_with(&[(12, 10), (3, 300), (40, 0)]);
        let mut s = LogDownload::new(Some(dir));
        let all = list(&mut s, 0, u16::MAX);
        let got: Vec<_> = all.iter().map(|e| (e.id, e.num_logs, e.last_log_num, e.size)).collect();
        assert_eq!(got, vec![(1, 3, 3, 300), (2, 3, 3, 10), (3, 3, 3, 0)]);
        assert!(all.iter().all(|e| e.time_utc > 1_600_000_000), "mtime in seconds since 1970");
        let one: Vec<_> = list(&mut s, 2, 2).iter().map(|e| (e.id, e.last_log_num)).collect();
        assert_eq!(one, vec![(2, 2)]);
    }

    #[test]
    fn an_empty_or_absent_directory_lists_one_entry_with_id_zero() {
        let (_tmp, dir) = dir_with(&[]);
        for dir in [Some(dir), Some(LogDirectory::new("/nonexistent/kestrel-logs")), None] {
            let mut s = LogDownload::new(dir);
            let got: Vec<_> = list(&mut s, 0, u16::MAX).iter().map(|e| (e.id, e.num_logs, e.size)).collect();
            assert_eq!(got, vec![(0, 0, 0)]);
        }
    }

    #[test]
    fn a_download_is_the_file_in_90_byte_chunks_ending_with_a_short_one() {
        let (tmp, dir) = dir_with(&[(1, 1000), (2, 180)]);
        let mut s = LogDownload::new(Some(dir));
        let chunks = download(&mut s, 1, 0, u32::MAX);
        let mut bytes = Vec::new();
        for (i, c) in chunks.iter().enumerate() {
            assert_eq!((c.id, c.ofs as usize), (1, i * LOG_DATA_BYTES));
            assert!(c.data[usize::from(c.count)..].iter().all(|&b| b == 0), "padding is zeros");
            bytes.extend_from_slice(&c.data[..usize::from(c.count)]);
        }
        assert_eq!(bytes, std::fs::read(tmp.path().join(log_file_name(1))).expect("read"));
        assert_eq!(chunks.last().map(|c| c.count), Some((1000 % 90) as u8));
        // A file of whole chunks ends on its last full chunk (the client knows the size from
        // LOG_ENTRY); a request at its end gets one zero-length chunk.
        let whole = download(&mut s, 2, 0, u32::MAX);
        assert_eq!(whole.iter().map(|c| c.count).collect::<Vec<_>>(), vec![90, 90]);
        let past = download(&mut s, 2, 180, u32::MAX);
        assert_eq!(past.iter().map(|c| (c.ofs, c.count)).collect::<Vec<_>>(), vec![(180, 0)]);
        // From an offset, a given count.
        let part = download(&mut s, 1, 100, 95);
        assert_eq!(part.iter().map(|c| (c.ofs, c.count)).collect::<Vec<_>>(), vec![(100, 90), (190, 5)]);
        assert!(download(&mut s, 3, 0, 90).is_empty(), "an unknown id is not answered");
        assert!(download(&mut s, 0, 0, 90).is_empty(), "nor is id 0");
    }

    #[test]
    fn armed_every_request_is_ignored_with_one_disarm_text_and_a_transfer_pauses() {
        let (_tmp, dir) = dir_with(&[(1, 10_000)]);
        let mut s = LogDownload::new(Some(dir));
        let req = MavMessage::LOG_REQUEST_DATA(LOG_REQUEST_DATA_DATA {
            ofs: 0,
            count: u32::MAX,
            id: 1,
            target_system: 1,
            target_component: 1,
        });
        assert_eq!(s.on_message(GCS, &req, Time::ZERO).expect("log").mav.len(), LOG_DATA_PER_TICK);
        s.set_armed(true);
        assert!(s.on_tick(Time::ZERO).mav.is_empty(), "no data while armed");
        let texts: Vec<_> =
            (0..3).map(|_| s.on_message(GCS, &req, Time::ZERO).expect("log").mav.len()).collect();
        assert_eq!(texts, vec![1, 0, 0], "one STATUSTEXT");
        s.set_armed(false);
        assert_eq!(s.on_tick(Time::ZERO).mav.len(), LOG_DATA_PER_TICK, "resumes disarmed");
        let end = MavMessage::LOG_REQUEST_END(LOG_REQUEST_END_DATA { target_system: 1, target_component: 1 });
        assert!(s.on_message(GCS, &end, Time::ZERO).expect("log").mav.is_empty());
        assert!(s.on_tick(Time::ZERO).mav.is_empty(), "ended");
    }

    #[test]
    fn erase_removes_every_log_and_nothing_else() {
        let (tmp, dir) = dir_with(&[(1, 10), (2, 10)]);
        let mut s = LogDownload::new(Some(dir));
        let erase = MavMessage::LOG_ERASE(LOG_ERASE_DATA { target_system: 1, target_component: 1 });
        assert!(s.on_message(GCS, &erase, Time::ZERO).expect("log").mav.is_empty(), "not answered");
        assert_eq!(list(&mut s, 0, u16::MAX).len(), 1, "the empty list's single entry");
        assert!(tmp.path().join("notes.txt").exists());
    }

    #[test]
    fn other_messages_are_not_this_services() {
        let mut s = LogDownload::new(None);
        let hb = MavMessage::HEARTBEAT(Default::default());
        assert!(s.on_message(GCS, &hb, Time::ZERO).is_none());
    }
}
