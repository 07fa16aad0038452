//! Flight logs cut short (the recorder killed, the disk full) or damaged: read as far as they
//! are readable by the reader, `kestrel report` and `kestrel replay`, which say how much was
//! lost; any bytes at all give a result or an error, never a panic.

use std::path::{Path, PathBuf};
use std::process::Command;

use kestrel::recorder::{LogReader, RecorderError};
use proptest::prelude::*;

/// 10 s of the simulator flying `leg-40m.plan`, recorded by `kestrel run --record`.
fn flight() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/sim-flight-10s.mcap")
}

fn flight_bytes() -> Vec<u8> {
    std::fs::read(flight()).expect("the recorded flight ships with the repo")
}

/// A copy of the flight with only its first `keep` bytes, under cargo's scratch directory.
fn cut_copy(name: &str, keep: usize) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("damaged_logs");
    std::fs::create_dir_all(&dir).expect("scratch dir");
    let path = dir.join(name);
    std::fs::write(&path, &flight_bytes()[..keep]).expect("write the cut copy");
    path
}

fn messages_in_whole_flight() -> u64 {
    let log = LogReader::open(&flight()).expect("the whole flight reads");
    assert!(log.damage().is_none());
    log.topics().iter().map(|t| t.message_count).sum()
}

#[test]
fn a_log_missing_its_last_20_bytes_loses_no_message() {
    let bytes = flight_bytes();
    let path = cut_copy("minus-20.mcap", bytes.len() - 20);
    let log = LogReader::open(&path).expect("read as far as it goes");
    let damage = log.damage().expect("the missing end is reported");
    assert_eq!(damage.messages_read, messages_in_whole_flight(), "{damage}");
    assert_eq!(log.raw().count() as u64, damage.messages_read);
    assert_eq!(damage.file_bytes, bytes.len() as u64 - 20);
    assert!(damage.intact_bytes < damage.file_bytes, "{damage}");
}

#[test]
fn a_log_cut_at_60_percent_keeps_the_messages_before_the_cut_and_says_so() {
    let bytes = flight_bytes();
    let keep = bytes.len() * 6 / 10;
    let log = LogReader::open(&cut_copy("sixty.mcap", keep)).expect("read as far as it goes");
    let damage = log.damage().expect("damage reported");
    let total = messages_in_whole_flight();
    // Chunks are about a twentieth of the file: the cut loses at most the one it falls in.
    assert!(damage.messages_read > total / 2 && damage.messages_read < total, "{damage} of {total}");
    assert!(damage.last_log_time_s.is_some_and(|t| (4.0..8.0).contains(&t)), "{damage}");
    let text = damage.to_string();
    assert!(text.contains(&format!("read {} messages", damage.messages_read)), "{text}");
    assert!(text.contains(&format!("of {keep}")), "{text}");
}

fn kestrel() -> Command {
    Command::new(env!("CARGO_BIN_EXE_kestrel"))
}

#[test]
fn kestrel_report_covers_what_a_cut_log_holds_and_says_what_was_lost() {
    let bytes = flight_bytes();
    let path = cut_copy("report-cut.mcap", bytes.len() * 8 / 10);
    let out = path.with_extension("plots");
    let run = kestrel().arg("report").arg(&path).arg("--out").arg(&out).output().expect("kestrel runs");
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(stdout.contains("damaged or cut short") && stdout.contains("messages"), "{stdout}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).expect("summary.json"))
            .expect("JSON");
    assert!(summary["log_damage"]["messages_read"].as_u64().is_some_and(|n| n > 0), "{summary:#}");
}

#[test]
fn kestrel_replay_runs_over_what_a_cut_log_holds_and_says_what_was_lost() {
    let bytes = flight_bytes();
    let path = cut_copy("replay-cut.mcap", bytes.len() * 8 / 10);
    let csv = path.with_extension("csv");
    let run =
        kestrel().args(["replay", "--log"]).arg(&path).arg("--out").arg(&csv).output().expect("kestrel runs");
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(stdout.contains("rows against") && stdout.contains("damaged or cut short"), "{stdout}");
    let rows = std::fs::read_to_string(&csv).expect("csv").lines().count();
    assert!(rows > 100, "{rows} rows");
}

#[test]
fn an_empty_file_is_not_an_mcap() {
    let path = cut_copy("empty.mcap", 0);
    let err = LogReader::open(&path).err().expect("refused");
    assert!(matches!(err, RecorderError::NotMcap { bytes: 0, .. }), "{err:?}");
}

/// An MCAP whose one zstd chunk decompresses cleanly to a message record claiming 2⁶² bytes:
/// given to the `mcap` reader as is, it sizes a buffer from that length and aborts the process.
fn chunk_with_a_lying_record() -> Vec<u8> {
    let mut inner = vec![0x05];
    inner.extend_from_slice(&(1u64 << 62).to_le_bytes());
    inner.extend_from_slice(&[0; 22]);
    let compressed = zstd::encode_all(&inner[..], 0).expect("zstd");
    let string = |s: &str| [&(s.len() as u32).to_le_bytes()[..], s.as_bytes()].concat();
    let record = |op: u8, body: &[u8]| [&[op][..], &(body.len() as u64).to_le_bytes(), body].concat();
    let header = [string("kestrel"), string("test")].concat();
    let mut chunk = Vec::new();
    chunk.extend_from_slice(&0u64.to_le_bytes());
    chunk.extend_from_slice(&0u64.to_le_bytes());
    chunk.extend_from_slice(&(inner.len() as u64).to_le_bytes());
    chunk.extend_from_slice(&0u32.to_le_bytes());
    chunk.extend_from_slice(&string("zstd"));
    chunk.extend_from_slice(&(compressed.len() as u64).to_le_bytes());
    chunk.extend_from_slice(&compressed);
    [mcap::MAGIC, &record(0x01, &header), &record(0x06, &chunk)].concat()
}

#[test]
fn a_chunk_whose_records_lie_about_their_length_is_damage_not_an_abort() {
    let bytes = chunk_with_a_lying_record();
    let log = LogReader::from_bytes(Path::new("lying.mcap"), bytes).expect("read as far as it goes");
    let damage = log.damage().expect("the chunk is reported");
    assert_eq!(damage.messages_read, 0);
    assert!(damage.reason.contains("chunk at byte"), "{damage}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn any_bytes_give_a_log_or_an_error(bytes in proptest::collection::vec(any::<u8>(), 0..4096), magic in any::<bool>()) {
        let bytes = if magic { [mcap::MAGIC, &bytes].concat() } else { bytes };
        if let Ok(log) = LogReader::from_bytes(Path::new("arbitrary.mcap"), bytes) {
            let _ = log.raw().count();
        }
    }

    #[test]
    fn a_cut_or_flipped_flight_gives_a_log_or_an_error(
        keep in 0.0f64..1.0,
        flips in proptest::collection::vec((0.0f64..1.0, 1u8..=255), 0..4),
    ) {
        let mut bytes = flight_bytes();
        bytes.truncate((bytes.len() as f64 * keep) as usize);
        let len = bytes.len();
        for (at, mask) in flips {
            if len > 0 {
                bytes[((len as f64 * at) as usize).min(len - 1)] ^= mask;
            }
        }
        if let Ok(log) = LogReader::from_bytes(Path::new("mutated.mcap"), bytes) {
            prop_assert_eq!(log.raw().filter(Result::is_ok).count() as u64,
                log.damage().map_or_else(|| log.topics().iter().map(|t| t.message_count).sum(), |d| d.messages_read));
        }
    }
}
