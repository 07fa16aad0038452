//! MAVLink FTP (mavlink.io "File Transfer Protocol"), server side, for a vehicle that serves no
//! files: every request is answered at once with the NAK the spec gives for it.
//!
//! Why answer at all: MAVProxy and QGroundControl first try to fetch parameters (and missions)
//! as files (`@PARAM/param.pck`) over FTP. Unanswered, they retry for ~12 s before falling back
//! to PARAM_REQUEST_LIST; a `FileNotFound` NAK makes them fall back at once. AUTOPILOT_VERSION
//! does not claim MAV_PROTOCOL_CAPABILITY_FTP, since no transfer can succeed.
//!
//! The answers, stateless, so a re-sent request (same sequence number) gets the same one, as
//! the spec wants:
//! * `None` and `ResetSessions`: ACK (there is nothing to reset);
//! * requests naming a path (open for reading, list, CRC, remove, truncate, rename):
//!   `FileNotFound`;
//! * requests creating something (create file/directory, open for writing): `FileProtected`,
//!   the file system being read-only (and empty);
//! * requests on a session (read, burst read, write, terminate): `InvalidSession`, as no
//!   session is ever opened;
//! * any other opcode: `UnknownCommand`. ACKs and NAKs (replies, not requests) get no answer,
//!   so two servers can never ping-pong.

use mavlink::dialects::ardupilotmega::{FILE_TRANSFER_PROTOCOL_DATA, MavFtpErr, MavFtpOpcode, MavMessage};

use super::Sender;

/// Byte offsets in the FTP payload (mavlink.io FTP "Payload Format").
const SEQ: usize = 0;
const SESSION: usize = 2;
const OPCODE: usize = 3;
const SIZE: usize = 4;
const REQ_OPCODE: usize = 5;
const DATA: usize = 12;

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
const TRUNCATE_FILE: u8 = MavFtpOpcode::MAV_FTP_OPCODE_TRUNCATEFILE as u8;
const RENAME: u8 = MavFtpOpcode::MAV_FTP_OPCODE_RENAME as u8;
const CALC_FILE_CRC32: u8 = MavFtpOpcode::MAV_FTP_OPCODE_CALCFILECRC as u8;
const BURST_READ_FILE: u8 = MavFtpOpcode::MAV_FTP_OPCODE_BURSTREADFILE as u8;
const LIST_DIRECTORY_WITH_TIME: u8 = MavFtpOpcode::MAV_FTP_OPCODE_LISTDIRECTORYWITHTIME as u8;
const ACK: u8 = MavFtpOpcode::MAV_FTP_OPCODE_ACK as u8;
const NAK: u8 = MavFtpOpcode::MAV_FTP_OPCODE_NAK as u8;

/// The answer to a FILE_TRANSFER_PROTOCOL request from `from`; `None` for replies (ACK/NAK).
pub fn answer(from: Sender, request: &FILE_TRANSFER_PROTOCOL_DATA) -> Option<MavMessage> {
    let p = &request.payload;
    let opcode = p[OPCODE];
    let error = match opcode {
        ACK | NAK => return None,
        NONE | RESET_SESSIONS => None,
        LIST_DIRECTORY
        | LIST_DIRECTORY_WITH_TIME
        | OPEN_FILE_RO
        | CALC_FILE_CRC32
        | REMOVE_FILE
        | REMOVE_DIRECTORY
        | TRUNCATE_FILE
        | RENAME => Some(MavFtpErr::MAV_FTP_ERR_FILENOTFOUND),
        CREATE_FILE | CREATE_DIRECTORY | OPEN_FILE_WO => Some(MavFtpErr::MAV_FTP_ERR_FILEPROTECTED),
        READ_FILE | BURST_READ_FILE | WRITE_FILE | TERMINATE_SESSION => {
            Some(MavFtpErr::MAV_FTP_ERR_INVALIDSESSION)
        }
        _ => Some(MavFtpErr::MAV_FTP_ERR_UNKNOWNCOMMAND),
    };
    let mut payload = [0u8; 251];
    // The reply's sequence number is the request's plus one; the session is echoed.
    let seq = u16::from_le_bytes([p[SEQ], p[SEQ + 1]]).wrapping_add(1);
    payload[SEQ..SEQ + 2].copy_from_slice(&seq.to_le_bytes());
    payload[SESSION] = p[SESSION];
    payload[REQ_OPCODE] = opcode;
    match error {
        None => payload[OPCODE] = ACK,
        Some(e) => {
            payload[OPCODE] = NAK;
            payload[SIZE] = 1;
            payload[DATA] = e as u8;
        }
    }
    Some(MavMessage::FILE_TRANSFER_PROTOCOL(FILE_TRANSFER_PROTOCOL_DATA {
        target_network: 0,
        target_system: from.target_system(),
        target_component: from.component_id,
        payload,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    const GCS: Sender = Sender { system_id: 255, component_id: 190 };

    fn request(seq: u16, session: u8, opcode: u8, path: &str) -> FILE_TRANSFER_PROTOCOL_DATA {
        let mut payload = [0u8; 251];
        payload[SEQ..SEQ + 2].copy_from_slice(&seq.to_le_bytes());
        payload[SESSION] = session;
        payload[OPCODE] = opcode;
        payload[SIZE] = u8::try_from(path.len()).expect("short path");
        payload[DATA..DATA + path.len()].copy_from_slice(path.as_bytes());
        FILE_TRANSFER_PROTOCOL_DATA { target_network: 0, target_system: 1, target_component: 1, payload }
    }

    /// (opcode, size, req_opcode, data[0], seq, session, target) of the answer.
    fn fields(msg: Option<MavMessage>) -> (u8, u8, u8, u8, u16, u8, (u8, u8)) {
        let Some(MavMessage::FILE_TRANSFER_PROTOCOL(r)) = msg else { panic!("no FTP answer") };
        let p = r.payload;
        let seq = u16::from_le_bytes([p[SEQ], p[SEQ + 1]]);
        (p[OPCODE], p[SIZE], p[REQ_OPCODE], p[DATA], seq, p[SESSION], (r.target_system, r.target_component))
    }

    #[test]
    fn a_parameter_file_request_is_refused_as_not_found_echoing_session_and_sequence() {
        let open = request(41, 181, OPEN_FILE_RO, "@PARAM/param.pck?withdefaults=1");
        let nak = (NAK, 1, OPEN_FILE_RO, MavFtpErr::MAV_FTP_ERR_FILENOTFOUND as u8, 42, 181, (255, 190));
        assert_eq!(fields(answer(GCS, &open)), nak);
        // A re-sent request gets the same answer.
        assert_eq!(fields(answer(GCS, &open)), nak);
        let wrapped = fields(answer(GCS, &request(u16::MAX, 3, OPEN_FILE_RO, "/x")));
        assert_eq!((wrapped.4, wrapped.5), (0, 3), "the sequence number wraps");
    }

    #[test]
    fn every_opcode_gets_the_spec_answer_and_replies_get_none() {
        use MavFtpErr::*;
        let cases = [
            (NONE, None),
            (RESET_SESSIONS, None),
            (LIST_DIRECTORY, Some(MAV_FTP_ERR_FILENOTFOUND)),
            (LIST_DIRECTORY_WITH_TIME, Some(MAV_FTP_ERR_FILENOTFOUND)),
            (CALC_FILE_CRC32, Some(MAV_FTP_ERR_FILENOTFOUND)),
            (REMOVE_FILE, Some(MAV_FTP_ERR_FILENOTFOUND)),
            (REMOVE_DIRECTORY, Some(MAV_FTP_ERR_FILENOTFOUND)),
            (TRUNCATE_FILE, Some(MAV_FTP_ERR_FILENOTFOUND)),
            (RENAME, Some(MAV_FTP_ERR_FILENOTFOUND)),
            (CREATE_FILE, Some(MAV_FTP_ERR_FILEPROTECTED)),
            (CREATE_DIRECTORY, Some(MAV_FTP_ERR_FILEPROTECTED)),
            (OPEN_FILE_WO, Some(MAV_FTP_ERR_FILEPROTECTED)),
            (READ_FILE, Some(MAV_FTP_ERR_INVALIDSESSION)),
            (BURST_READ_FILE, Some(MAV_FTP_ERR_INVALIDSESSION)),
            (WRITE_FILE, Some(MAV_FTP_ERR_INVALIDSESSION)),
            (TERMINATE_SESSION, Some(MAV_FTP_ERR_INVALIDSESSION)),
            (17, Some(MAV_FTP_ERR_UNKNOWNCOMMAND)),
            (200, Some(MAV_FTP_ERR_UNKNOWNCOMMAND)),
        ];
        for (opcode, error) in cases {
            let (op, size, req, data, seq, ..) = fields(answer(GCS, &request(7, 0, opcode, "/")));
            assert_eq!((req, seq), (opcode, 8), "opcode {opcode}");
            match error {
                None => assert_eq!((op, size), (ACK, 0), "opcode {opcode}"),
                Some(e) => assert_eq!((op, size, data), (NAK, 1, e as u8), "opcode {opcode}"),
            }
        }
        assert!(answer(GCS, &request(7, 0, ACK, "")).is_none());
        assert!(answer(GCS, &request(7, 0, NAK, "")).is_none());
    }
}
