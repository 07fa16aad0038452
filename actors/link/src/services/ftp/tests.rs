use super::*;
use crate::config::ParamSpec;
use crate::services::log_download::log_file_name;

const GCS: Sender = Sender { system_id: 255, component_id: 190 };

struct Fixture {
    dir: std::path::PathBuf,
    server: FtpServer,
    params: ParamTable,
    seq: u16,
}

impl Drop for Fixture {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

fn fixture(name: &str, logs: &[(u32, usize)]) -> Fixture {
    let dir = std::env::temp_dir().join(format!("kestrel-link-ftp-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch dir");
    for &(number, size) in logs {
        let bytes: Vec<u8> = (0..size).map(|i| (i * 31 + 7) as u8).collect();
        std::fs::write(dir.join(log_file_name(number)), bytes).expect("write");
    }
    std::fs::write(dir.join("secret.txt"), "not served").expect("write");
    let specs = ["RTL_ALT_M", "WPNAV_SPEED"]
        .iter()
        .map(|n| ParamSpec {
            name: (*n).into(),
            value: 12.5,
            min: f64::NEG_INFINITY,
            max: f64::INFINITY,
            kind: crate::config::ParamKind::Real32,
            unit: String::new(),
        })
        .collect();
    let params = ParamTable::new(specs).expect("params");
    Fixture { server: FtpServer::new(Some(LogDirectory::new(&dir))), dir, params, seq: 0 }
}

fn request(
    seq: u16,
    session: u8,
    opcode: u8,
    offset: u32,
    size: u8,
    data: &[u8],
) -> FILE_TRANSFER_PROTOCOL_DATA {
    let mut payload = [0u8; 251];
    payload[SEQ..SEQ + 2].copy_from_slice(&seq.to_le_bytes());
    payload[SESSION] = session;
    payload[OPCODE] = opcode;
    payload[SIZE] = size;
    payload[OFFSET..OFFSET + 4].copy_from_slice(&offset.to_le_bytes());
    payload[DATA..DATA + data.len()].copy_from_slice(data);
    FILE_TRANSFER_PROTOCOL_DATA { target_network: 0, target_system: 1, target_component: 1, payload }
}

impl Fixture {
    fn send(&mut self, opcode: u8, offset: u32, size: u8, data: &[u8]) -> Vec<[u8; 251]> {
        self.seq = self.seq.wrapping_add(2);
        let r = request(self.seq, 3, opcode, offset, size, data);
        self.server
            .on_request(GCS, &r, &self.params, Time::ZERO)
            .into_iter()
            .map(|m| match m {
                MavMessage::FILE_TRANSFER_PROTOCOL(f) => f.payload,
                other => panic!("{other:?}"),
            })
            .collect()
    }

    fn path(&mut self, opcode: u8, path: &str) -> [u8; 251] {
        let replies = self.send(opcode, 0, path.len() as u8, path.as_bytes());
        assert_eq!(replies.len(), 1);
        replies[0]
    }

    /// The whole file at `path`, by ReadFile.
    fn read(&mut self, path: &str) -> Vec<u8> {
        let open = self.path(OPEN_FILE_RO, path);
        assert_eq!(open[OPCODE], ACK, "open {path}");
        let size = u32::from_le_bytes([open[DATA], open[DATA + 1], open[DATA + 2], open[DATA + 3]]);
        let mut bytes = Vec::new();
        loop {
            let r = self.send(READ_FILE, bytes.len() as u32, DATA_BYTES as u8, &[])[0];
            if r[OPCODE] == NAK {
                assert_eq!(r[DATA], MavFtpErr::MAV_FTP_ERR_EOF as u8);
                break;
            }
            bytes.extend_from_slice(&r[DATA..DATA + usize::from(r[SIZE])]);
        }
        assert_eq!(bytes.len() as u32, size);
        assert_eq!(self.send(TERMINATE_SESSION, 0, 0, &[])[0][OPCODE], ACK);
        bytes
    }
}

fn entries(r: &[u8; 251]) -> Vec<String> {
    let data = &r[DATA..DATA + usize::from(r[SIZE])];
    data.split(|&b| b == 0)
        .filter(|e| !e.is_empty())
        .map(|e| String::from_utf8_lossy(e).into_owned())
        .collect()
}

#[test]
fn the_root_lists_the_logs_and_the_log_directory_only_logs() {
    let mut f = fixture("list", &[(2, 500), (1, 10)]);
    assert_eq!(entries(&f.path(LIST_DIRECTORY, "/")), vec!["Dlogs"]);
    assert_eq!(entries(&f.path(LIST_DIRECTORY, "/logs/")), vec!["F00000001.mcap\t10", "F00000002.mcap\t500"]);
    let params = entries(&f.path(LIST_DIRECTORY, "@PARAM"));
    assert_eq!(params.len(), 1);
    assert!(params[0].starts_with("Fparam.pck\t"));
    // Past the last entry: EndOfFile.
    let past = f.send(LIST_DIRECTORY, 2, 5, b"/logs")[0];
    assert_eq!((past[OPCODE], past[DATA]), (NAK, MavFtpErr::MAV_FTP_ERR_EOF as u8));
    let missing = f.path(LIST_DIRECTORY, "/etc");
    assert_eq!((missing[OPCODE], missing[DATA]), (NAK, MavFtpErr::MAV_FTP_ERR_FILENOTFOUND as u8));
}

#[test]
fn a_log_reads_back_byte_for_byte_by_read_and_by_burst() {
    let mut f = fixture("read", &[(1, 1000)]);
    let want = std::fs::read(f.dir.join(log_file_name(1))).expect("read");
    assert_eq!(f.read("/logs/00000001.mcap"), want);
    assert_eq!(f.path(OPEN_FILE_RO, "logs/00000001.mcap")[OPCODE], ACK);
    let burst = f.send(BURST_READ_FILE, 0, 0, &[]);
    let mut bytes = Vec::new();
    for r in &burst[..burst.len() - 1] {
        assert_eq!(r[OPCODE], ACK);
        assert_eq!(
            u32::from_le_bytes([r[OFFSET], r[OFFSET + 1], r[OFFSET + 2], r[OFFSET + 3]]) as usize,
            bytes.len()
        );
        bytes.extend_from_slice(&r[DATA..DATA + usize::from(r[SIZE])]);
    }
    let last = burst.last().expect("replies");
    assert_eq!((last[OPCODE], last[DATA], last[BURST_COMPLETE]), (NAK, MavFtpErr::MAV_FTP_ERR_EOF as u8, 1));
    assert_eq!(bytes, want);
    let seqs: Vec<u16> = burst.iter().map(|r| u16::from_le_bytes([r[SEQ], r[SEQ + 1]])).collect();
    assert!(seqs.windows(2).all(|w| w[1] == w[0].wrapping_add(1)), "each reply its own sequence number");
}

#[test]
fn a_long_burst_ends_flagged_complete_for_the_next_request() {
    let mut f = fixture("burst", &[(1, DATA_BYTES * BURST_PACKETS + 5)]);
    assert_eq!(f.path(OPEN_FILE_RO, "/logs/00000001.mcap")[OPCODE], ACK);
    let burst = f.send(BURST_READ_FILE, 0, 0, &[]);
    assert_eq!(burst.len(), BURST_PACKETS);
    assert!(burst[..BURST_PACKETS - 1].iter().all(|r| r[BURST_COMPLETE] == 0));
    assert_eq!(burst[BURST_PACKETS - 1][BURST_COMPLETE], 1);
    let rest = f.send(BURST_READ_FILE, (DATA_BYTES * BURST_PACKETS) as u32, 0, &[]);
    assert_eq!(rest.iter().map(|r| (r[OPCODE], r[SIZE])).collect::<Vec<_>>(), vec![(ACK, 5), (NAK, 1)]);
}

#[test]
fn the_parameter_file_holds_every_parameter_and_ignores_its_query() {
    let mut f = fixture("pck", &[]);
    let bytes = f.read("@PARAM/param.pck?withdefaults=1");
    assert_eq!(bytes, param_pack::encode(&f.params.list()));
    assert_eq!(u16::from_le_bytes([bytes[2], bytes[3]]), 2);
}

#[test]
fn nothing_outside_the_two_directories_opens_and_a_second_open_fails() {
    let mut f = fixture("paths", &[(1, 10)]);
    for path in ["/logs/secret.txt", "/logs/../logs/00000001.mcap", "/etc/passwd", "logs/00000002.mcap", ""] {
        let r = f.send(OPEN_FILE_RO, 0, path.len() as u8, path.as_bytes())[0];
        assert_eq!(r[OPCODE], NAK, "{path}");
    }
    assert_eq!(f.path(OPEN_FILE_RO, "/logs/00000001.mcap")[OPCODE], ACK);
    let again = f.path(OPEN_FILE_RO, "/logs/00000001.mcap");
    assert_eq!((again[OPCODE], again[DATA]), (NAK, MavFtpErr::MAV_FTP_ERR_FAIL as u8));
}

#[test]
fn a_repeated_request_gets_the_same_reply_so_a_lost_open_ack_is_not_a_second_open() {
    let mut f = fixture("resend", &[(1, 10)]);
    let open = request(40, 9, OPEN_FILE_RO, 0, 19, b"/logs/00000001.mcap");
    let first = f.server.on_request(GCS, &open, &f.params, Time::ZERO);
    let again = f.server.on_request(GCS, &open, &f.params, Time::ZERO);
    assert_eq!(first, again);
}

#[test]
fn writes_are_refused_as_a_read_only_file_system_and_crc_is_ardupilots() {
    let mut f = fixture("ro", &[(1, 10)]);
    for op in [CREATE_FILE, OPEN_FILE_WO, CREATE_DIRECTORY, REMOVE_FILE, REMOVE_DIRECTORY, RENAME] {
        let r = f.path(op, "/logs/00000001.mcap");
        assert_eq!(
            (r[OPCODE], r[SIZE], r[DATA], r[DATA + 1]),
            (NAK, 2, MavFtpErr::MAV_FTP_ERR_FAILERRNO as u8, EROFS)
        );
    }
    assert!(f.dir.join(log_file_name(1)).exists());
    let w = f.send(WRITE_FILE, 0, 1, b"x")[0];
    assert_eq!((w[OPCODE], w[DATA]), (NAK, MavFtpErr::MAV_FTP_ERR_FILENOTFOUND as u8));
    // zlib.crc32(b"123456789", 0xffffffff) ^ 0xffffffff, as MAVProxy computes the vehicle's CRC.
    assert_eq!(crc32(0, b"123456789"), 0x2dfd_2d88);
    let crc = f.path(CALC_FILE_CRC32, "/logs/00000001.mcap");
    let want = crc32(0, &std::fs::read(f.dir.join(log_file_name(1))).expect("read"));
    assert_eq!((crc[OPCODE], &crc[DATA..DATA + 4]), (ACK, &want.to_le_bytes()[..]));
    assert_eq!(f.send(17, 0, 0, &[])[0][DATA], MavFtpErr::MAV_FTP_ERR_UNKNOWNCOMMAND as u8);
    assert_eq!(f.send(NONE, 0, 0, &[])[0][OPCODE], ACK);
    assert_eq!(f.send(RESET_SESSIONS, 0, 0, &[])[0][OPCODE], ACK);
    assert!(f.send(ACK, 0, 0, &[]).is_empty() && f.send(NAK, 0, 0, &[]).is_empty());
}
