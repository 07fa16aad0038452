//! MAVLink FTP (mavlink.io "File Transfer Protocol"), server side, read-only, over two
//! directories: `logs/` (the vehicle's numbered MCAP logs, [`LogDirectory`]) and `@PARAM/`
//! holding `param.pck` (every parameter, [`param_pack`]), answered as ArduCopter's `GCS_FTP`
//! answers them.
//!
//! * ListDirectory: `F<name>\t<size>\0` per file, `D<name>\0` per directory, as many whole
//!   entries as fit in 239 bytes, from the entry `offset`; past the last one a NAK EndOfFile.
//!   `/` lists `logs`; `@PARAM` is not listed there but is reached by name, as on ArduCopter
//!   (whose root lists `@ROMFS`, `@SYS` and its SD card's directories).
//! * OpenFileRO: an ACK with the file's size (4 bytes); a second open on a session a NAK Fail.
//!   `@PARAM/param.pck` may carry a query (`?withdefaults=1`), ignored: the file has no defaults
//!   (its magic says so) and readers take the values as their own defaults.
//! * ReadFile: up to `size` (≤ 239) bytes at `offset`; at or past the end a NAK EndOfFile.
//! * BurstReadFile: ACKs of 239 bytes (or `size`) from `offset`, [`BURST_PACKETS`] per request,
//!   the last flagged `burst_complete` so the client asks for the next burst; the end of the file
//!   is a NAK EndOfFile flagged `burst_complete`. ArduPilot sends up to 2000 per request; ours
//!   are shorter so a burst never overflows a ground station's socket buffer.
//! * TerminateSession and ResetSessions close sessions and ACK; None ACKs.
//! * CalcFileCRC32: ArduPilot's CRC-32 (reflected 0xEDB88320, seed 0, no final inversion).
//! * Writes (CreateFile, OpenFileWO, CreateDirectory, RemoveFile, RemoveDirectory, Rename): a NAK
//!   FailErrno with errno EROFS, as ArduPilot's file system answers for a read-only one;
//!   WriteFile without a write session FileNotFound, as ArduPilot; TruncateFile and unknown
//!   opcodes UnknownCommand.
//! * A re-sent request (same session, sequence one before the last reply's) gets the last reply
//!   again, so an OpenFileRO whose ACK was lost is not refused as a second open.
//!
//! Paths outside these two directories, and names in `logs/` that are not log names, are
//! FileNotFound: nothing else of the companion computer's disk is reachable.
//!
//! Held by the tests in this file, `tests/gcs_log_download.rs` (pymavlink's mavftp, against
//! ArduCopter too) and `tests/gcs_pymavlink.rs` (MAVProxy fetching its parameters as `param.pck`).

use std::fs::File;
use std::io;
use std::os::unix::fs::FileExt;

use kestrel_proto::Time;
use mavlink::dialects::ardupilotmega::{FILE_TRANSFER_PROTOCOL_DATA, MavFtpErr, MavFtpOpcode, MavMessage};

use super::Sender;
use super::log_download::{LogDirectory, log_number};
use super::param_pack;
use super::params::ParamTable;

/// Byte offsets in the FTP payload (mavlink.io FTP "Payload Format").
const SEQ: usize = 0;
const SESSION: usize = 2;
const OPCODE: usize = 3;
const SIZE: usize = 4;
const REQ_OPCODE: usize = 5;
const BURST_COMPLETE: usize = 6;
const OFFSET: usize = 8;
const DATA: usize = 12;
/// Bytes of data in one message.
pub const DATA_BYTES: usize = 251 - DATA;

/// ACKs per BurstReadFile request (56 kB).
pub const BURST_PACKETS: usize = 240;

/// Sessions kept at once; the least recently used one is reused beyond it.
const MAX_SESSIONS: usize = 8;

/// Linux's EROFS, "read-only file system": ArduPilot sends errno with FailErrno.
const EROFS: u8 = 30;

const NONE: u8 = MavFtpOpcode::MAV_FTP_OPCODE_NONE as u8;
const TERMINATE_SESSION: u8 = MavFtpOpcode::MAV_FTP_OPCODE_TERMINATESESSION as u8;
const RESET_SESSIONS: u8 = MavFtpOpcode::MAV_FTP_OPCODE_RESETSESSION as u8;
const LIST_DIRECTORY: u8 = MavFtpOpcode::MAV_FTP_OPCODE_LISTDIRECTORY as u8;
const OPEN_FILE_RO: u8 = MavFtpOpcode::MAV_FTP_OPCODE_OPENFILERO as u8;
const READ_FILE: u8 = MavFtpOpcode::MAV_FTP_OPCODE_READFILE as u8;
const CREATE_FILE: u8 = MavFtpOpcode::MAV_FTP_OPCODE_CREATEFILE as u8;
const WRITE_FILE: u8 = MavFtpOpcode::MAV_FTP_OPCODE_WRITEFILE as u8;
const REMOVE_FILE: u8 = MavFtpOpcode::MAV_FTP_OPCODE_REMOVEFILE as u8;
const CREATE_DIRECTORY: u8 = MavFtpOpcode::MAV_FTP_OPCODE_CREATEDIRECTORY as u8;
const REMOVE_DIRECTORY: u8 = MavFtpOpcode::MAV_FTP_OPCODE_REMOVEDIRECTORY as u8;
const OPEN_FILE_WO: u8 = MavFtpOpcode::MAV_FTP_OPCODE_OPENFILEWO as u8;
const RENAME: u8 = MavFtpOpcode::MAV_FTP_OPCODE_RENAME as u8;
const CALC_FILE_CRC32: u8 = MavFtpOpcode::MAV_FTP_OPCODE_CALCFILECRC as u8;
const BURST_READ_FILE: u8 = MavFtpOpcode::MAV_FTP_OPCODE_BURSTREADFILE as u8;
const ACK: u8 = MavFtpOpcode::MAV_FTP_OPCODE_ACK as u8;
const NAK: u8 = MavFtpOpcode::MAV_FTP_OPCODE_NAK as u8;

/// The log directory's name under `/`.
const LOGS: &str = "logs";
const PARAM_DIR: &str = "@PARAM";
const PARAM_FILE: &str = "param.pck";

/// A file opened for reading.
#[derive(Debug)]
enum Content {
    Disk { file: File, size: u32 },
    Memory(Vec<u8>),
}

impl Content {
    fn size(&self) -> u32 {
        match self {
            Content::Disk { size, .. } => *size,
            Content::Memory(bytes) => u32::try_from(bytes.len()).unwrap_or(u32::MAX),
        }
    }

    /// Up to `buf.len()` bytes at `offset` (fewer only at the end).
    fn read_at(&self, buf: &mut [u8], offset: u32) -> io::Result<usize> {
        match self {
            Content::Memory(bytes) => {
                let start = (offset as usize).min(bytes.len());
                let n = buf.len().min(bytes.len() - start);
                buf[..n].copy_from_slice(&bytes[start..start + n]);
                Ok(n)
            }
            Content::Disk { file, .. } => {
                let mut done = 0;
                while done < buf.len() {
                    match file.read_at(&mut buf[done..], u64::from(offset) + done as u64) {
                        Ok(0) => break,
                        Ok(n) => done += n,
                        Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                        Err(e) => return Err(e),
                    }
                }
                Ok(done)
            }
        }
    }
}

#[derive(Debug)]
struct Session {
    owner: Sender,
    id: u8,
    file: Option<Content>,
    last_used: Time,
}

/// What a path names.
enum Node {
    Root,
    ParamDir,
    LogDir,
    ParamFile,
    Log(LogDirectory, String),
}

/// The FTP server.
#[derive(Debug)]
pub struct FtpServer {
    logs: Option<LogDirectory>,
    sessions: Vec<Session>,
    /// The last reply sent, with whom it went to: re-sent for a repeated request.
    last_reply: Option<(Sender, [u8; 251])>,
}

/// A reply under construction: the request's header echoed, sequence + 1.
struct Reply {
    payload: [u8; 251],
}

impl Reply {
    fn to(request: &[u8; 251]) -> Reply {
        let mut payload = [0u8; 251];
        let seq = u16::from_le_bytes([request[SEQ], request[SEQ + 1]]).wrapping_add(1);
        payload[SEQ..SEQ + 2].copy_from_slice(&seq.to_le_bytes());
        payload[SESSION] = request[SESSION];
        payload[REQ_OPCODE] = request[OPCODE];
        Reply { payload }
    }

    fn ack(mut self, offset: u32, data: &[u8]) -> [u8; 251] {
        self.payload[OPCODE] = ACK;
        self.payload[OFFSET..OFFSET + 4].copy_from_slice(&offset.to_le_bytes());
        // `data` is at most DATA_BYTES (239) long.
        self.payload[SIZE] = data.len() as u8;
        self.payload[DATA..DATA + data.len()].copy_from_slice(data);
        self.payload
    }

    fn nak(mut self, error: MavFtpErr) -> [u8; 251] {
        self.payload[OPCODE] = NAK;
        self.payload[SIZE] = 1;
        self.payload[DATA] = error as u8;
        self.payload
    }

    fn nak_errno(mut self, errno: u8) -> [u8; 251] {
        self.payload[OPCODE] = NAK;
        self.payload[SIZE] = 2;
        self.payload[DATA] = MavFtpErr::MAV_FTP_ERR_FAILERRNO as u8;
        self.payload[DATA + 1] = errno;
        self.payload
    }
}

impl FtpServer {
    /// A server over `logs` (`None`: `/logs` is absent) and the parameters.
    pub fn new(logs: Option<LogDirectory>) -> FtpServer {
        FtpServer { logs, sessions: Vec::new(), last_reply: None }
    }

    /// The answers to a FILE_TRANSFER_PROTOCOL request from `from`; none to replies (ACK/NAK),
    /// so two servers can never ping-pong.
    pub fn on_request(
        &mut self,
        from: Sender,
        request: &FILE_TRANSFER_PROTOCOL_DATA,
        params: &ParamTable,
        now: Time,
    ) -> Vec<MavMessage> {
        let p = &request.payload;
        let opcode = p[OPCODE];
        if opcode == ACK || opcode == NAK {
            return Vec::new();
        }
        if let Some((to, last)) = &self.last_reply {
            let seq = u16::from_le_bytes([p[SEQ], p[SEQ + 1]]);
            let last_seq = u16::from_le_bytes([last[SEQ], last[SEQ + 1]]);
            if *to == from
                && last[SESSION] == p[SESSION]
                && seq.wrapping_add(1) == last_seq
                && last[REQ_OPCODE] == opcode
            {
                return vec![message(from, *last)];
            }
        }
        let replies = self.answer(from, p, params, now);
        if let Some(last) = replies.last() {
            self.last_reply = Some((from, *last));
        }
        replies.into_iter().map(|r| message(from, r)).collect()
    }

    fn answer(&mut self, from: Sender, p: &[u8; 251], params: &ParamTable, now: Time) -> Vec<[u8; 251]> {
        let reply = Reply::to(p);
        let size = usize::from(p[SIZE]);
        let offset = u32::from_le_bytes([p[OFFSET], p[OFFSET + 1], p[OFFSET + 2], p[OFFSET + 3]]);
        let session_id = p[SESSION];
        let path = || path_of(p, size);
        let one = |r: [u8; 251]| vec![r];
        match p[OPCODE] {
            NONE => one(reply.ack(0, &[])),
            RESET_SESSIONS => {
                self.sessions.retain(|s| s.owner != from);
                one(reply.ack(0, &[]))
            }
            TERMINATE_SESSION => {
                self.sessions.retain(|s| !(s.owner == from && s.id == session_id));
                one(reply.ack(0, &[]))
            }
            LIST_DIRECTORY => one(match path() {
                None => reply.nak(MavFtpErr::MAV_FTP_ERR_INVALIDDATASIZE),
                Some(path) => self.list(reply, &path, offset, params),
            }),
            OPEN_FILE_RO => {
                let Some(path) = path() else {
                    return one(reply.nak(MavFtpErr::MAV_FTP_ERR_INVALIDDATASIZE));
                };
                let session = self.session(from, session_id, now);
                if session.file.is_some() {
                    return one(reply.nak(MavFtpErr::MAV_FTP_ERR_FAIL));
                }
                match self.open(&path, params) {
                    Ok(content) => {
                        let size = content.size();
                        self.session(from, session_id, now).file = Some(content);
                        one(reply.ack(0, &size.to_le_bytes()))
                    }
                    Err(e) => one(e.nak(reply)),
                }
            }
            READ_FILE => {
                let Some(content) = self.open_file(from, session_id, now) else {
                    return one(reply.nak(MavFtpErr::MAV_FTP_ERR_FILENOTFOUND));
                };
                let mut buf = [0u8; DATA_BYTES];
                let want = size.clamp(1, DATA_BYTES);
                match content.read_at(&mut buf[..want], offset) {
                    Ok(0) => one(reply.nak(MavFtpErr::MAV_FTP_ERR_EOF)),
                    Ok(n) => one(reply.ack(offset, &buf[..n])),
                    Err(e) => one(reply.nak_errno(errno(&e))),
                }
            }
            BURST_READ_FILE => {
                let Some(content) = self.open_file(from, session_id, now) else {
                    return one(reply.nak(MavFtpErr::MAV_FTP_ERR_FILENOTFOUND));
                };
                let max = if size == 0 { DATA_BYTES } else { size.min(DATA_BYTES) };
                burst(content, Reply::to(p), offset, max)
            }
            CALC_FILE_CRC32 => {
                let Some(path) = path() else {
                    return one(reply.nak(MavFtpErr::MAV_FTP_ERR_INVALIDDATASIZE));
                };
                one(match self.open(&path, params).and_then(|c| crc_of(&c).map_err(OpenError::Io)) {
                    Ok(crc) => reply.ack(0, &crc.to_le_bytes()),
                    Err(e) => e.nak(reply),
                })
            }
            CREATE_FILE | OPEN_FILE_WO | CREATE_DIRECTORY | REMOVE_FILE | REMOVE_DIRECTORY | RENAME => {
                one(reply.nak_errno(EROFS))
            }
            WRITE_FILE => match self.open_file(from, session_id, now) {
                // Open for reading, as in ArduPilot: the wrong mode.
                Some(_) => one(reply.nak(MavFtpErr::MAV_FTP_ERR_FAIL)),
                None => one(reply.nak(MavFtpErr::MAV_FTP_ERR_FILENOTFOUND)),
            },
            _ => one(reply.nak(MavFtpErr::MAV_FTP_ERR_UNKNOWNCOMMAND)),
        }
    }

    /// The session `id` of `from`, made (reusing the least recently used beyond
    /// [`MAX_SESSIONS`]) if new.
    fn session(&mut self, from: Sender, id: u8, now: Time) -> &mut Session {
        let index = match self.sessions.iter().position(|s| s.owner == from && s.id == id) {
            Some(i) => i,
            None => {
                if self.sessions.len() >= MAX_SESSIONS
                    && let Some(oldest) = (0..self.sessions.len()).min_by_key(|&i| self.sessions[i].last_used)
                {
                    self.sessions.remove(oldest);
                }
                self.sessions.push(Session { owner: from, id, file: None, last_used: now });
                self.sessions.len() - 1
            }
        };
        let session = &mut self.sessions[index];
        session.last_used = now;
        session
    }

    fn open_file(&mut self, from: Sender, id: u8, now: Time) -> Option<&Content> {
        let session = self.sessions.iter_mut().find(|s| s.owner == from && s.id == id)?;
        session.last_used = now;
        session.file.as_ref()
    }

    fn resolve(&self, path: &str) -> Option<Node> {
        let path = path.trim_start_matches('/').trim_end_matches('/');
        let (dir, name) = match path.split_once('/') {
            Some((dir, name)) => (dir, Some(name)),
            None => (path, None),
        };
        match (dir, name) {
            ("", None) => Some(Node::Root),
            (PARAM_DIR, None) => Some(Node::ParamDir),
            (PARAM_DIR, Some(file)) if file.split('?').next() == Some(PARAM_FILE) => Some(Node::ParamFile),
            (LOGS, None) => self.logs.as_ref().map(|_| Node::LogDir),
            (LOGS, Some(file)) => {
                let logs = self.logs.as_ref()?;
                log_number(file).map(|_| Node::Log(logs.clone(), file.to_owned()))
            }
            _ => None,
        }
    }

    fn open(&self, path: &str, params: &ParamTable) -> Result<Content, OpenError> {
        match self.resolve(path) {
            Some(Node::ParamFile) => Ok(Content::Memory(param_pack::encode(&params.list()))),
            Some(Node::Log(logs, name)) => {
                let file = File::open(logs.path().join(name)).map_err(OpenError::Io)?;
                let size = file.metadata().map_err(OpenError::Io)?.len();
                Ok(Content::Disk { file, size: u32::try_from(size).unwrap_or(u32::MAX) })
            }
            Some(Node::Root | Node::ParamDir | Node::LogDir) => Err(OpenError::IsDirectory),
            None => Err(OpenError::NotFound),
        }
    }

    fn list(&self, reply: Reply, path: &str, offset: u32, params: &ParamTable) -> [u8; 251] {
        let entries: Vec<String> = match self.resolve(path) {
            Some(Node::Root) => self.logs.iter().map(|_| format!("D{LOGS}")).collect(),
            Some(Node::ParamDir) => {
                vec![format!("F{PARAM_FILE}\t{}", param_pack::encode(&params.list()).len())]
            }
            Some(Node::LogDir) => match self.logs.as_ref().map(LogDirectory::list) {
                Some(Ok(logs)) => logs
                    .iter()
                    .filter_map(|l| Some(format!("F{}\t{}", l.path.file_name()?.to_str()?, l.size_bytes)))
                    .collect(),
                Some(Err(e)) => return reply.nak_errno(errno(&e)),
                None => return reply.nak(MavFtpErr::MAV_FTP_ERR_FILENOTFOUND),
            },
            Some(Node::ParamFile | Node::Log(..)) => return reply.nak_errno(20), // ENOTDIR
            None => return reply.nak(MavFtpErr::MAV_FTP_ERR_FILENOTFOUND),
        };
        let mut data = Vec::new();
        for entry in entries.iter().skip(offset as usize) {
            // Each entry ends with a NUL; only whole entries are sent.
            if data.len() + entry.len() + 1 > DATA_BYTES {
                break;
            }
            data.extend_from_slice(entry.as_bytes());
            data.push(0);
        }
        if data.is_empty() {
            return reply.nak(MavFtpErr::MAV_FTP_ERR_EOF);
        }
        reply.ack(offset, &data)
    }
}

/// Why a path could not be opened.
enum OpenError {
    NotFound,
    IsDirectory,
    Io(io::Error),
}

impl OpenError {
    fn nak(self, reply: Reply) -> [u8; 251] {
        match self {
            OpenError::NotFound => reply.nak(MavFtpErr::MAV_FTP_ERR_FILENOTFOUND),
            OpenError::IsDirectory => reply.nak_errno(21), // EISDIR
            OpenError::Io(e) if e.kind() == io::ErrorKind::NotFound => {
                reply.nak(MavFtpErr::MAV_FTP_ERR_FILENOTFOUND)
            }
            OpenError::Io(e) => reply.nak_errno(errno(&e)),
        }
    }
}

/// The OS error number of `e` for a FailErrno NAK (EIO when it has none).
fn errno(e: &io::Error) -> u8 {
    e.raw_os_error().and_then(|n| u8::try_from(n).ok()).unwrap_or(5)
}

/// The path in a request's data: `size` bytes, or up to a NUL within them; `None` when the size
/// is 0 or exceeds the data field, or the bytes are not UTF-8.
fn path_of(p: &[u8; 251], size: usize) -> Option<String> {
    if size == 0 || size > DATA_BYTES {
        return None;
    }
    let bytes = &p[DATA..DATA + size];
    let end = bytes.iter().position(|&b| b == 0).unwrap_or(size);
    std::str::from_utf8(&bytes[..end]).ok().map(str::to_owned)
}

/// A BurstReadFile's replies from `offset`, `max` bytes each.
fn burst(content: &Content, template: Reply, mut offset: u32, max: usize) -> Vec<[u8; 251]> {
    let mut out = Vec::new();
    let mut payload = template.payload;
    for i in 0..BURST_PACKETS {
        let reply = Reply { payload };
        let mut buf = [0u8; DATA_BYTES];
        match content.read_at(&mut buf[..max], offset) {
            Ok(0) => {
                let mut nak = reply.nak(MavFtpErr::MAV_FTP_ERR_EOF);
                nak[BURST_COMPLETE] = 1;
                out.push(nak);
                break;
            }
            Ok(n) => {
                let mut ack = reply.ack(offset, &buf[..n]);
                ack[BURST_COMPLETE] = u8::from(i == BURST_PACKETS - 1);
                out.push(ack);
                offset = offset.saturating_add(n as u32);
            }
            Err(e) => {
                let mut nak = reply.nak_errno(errno(&e));
                nak[BURST_COMPLETE] = 1;
                out.push(nak);
                break;
            }
        }
        // Every reply of a burst has its own sequence number.
        let seq = u16::from_le_bytes([payload[SEQ], payload[SEQ + 1]]).wrapping_add(1);
        payload[SEQ..SEQ + 2].copy_from_slice(&seq.to_le_bytes());
    }
    out
}

/// ArduPilot's file CRC-32: the reflected polynomial 0xEDB88320 from a zero seed, no final
/// inversion (what `crc_crc32(0, …)` gives and pymavlink's mavftp compares against).
pub fn crc32(mut crc: u32, data: &[u8]) -> u32 {
    for &byte in data {
        crc ^= u32::from(byte);
        for _ in 0..8 {
            crc = if crc & 1 != 0 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
        }
    }
    crc
}

fn crc_of(content: &Content) -> io::Result<u32> {
    let mut crc = 0;
    let mut offset = 0u32;
    let mut buf = vec![0u8; 64 * 1024];
    loop {
        let n = content.read_at(&mut buf, offset)?;
        if n == 0 {
            return Ok(crc);
        }
        crc = crc32(crc, &buf[..n]);
        offset = offset.saturating_add(n as u32);
    }
}

fn message(to: Sender, payload: [u8; 251]) -> MavMessage {
    MavMessage::FILE_TRANSFER_PROTOCOL(FILE_TRANSFER_PROTOCOL_DATA {
        target_network: 0,
        target_system: to.target_system(),
        target_component: to.component_id,
        payload,
    })
}

#[cfg(test)]
mod tests;
