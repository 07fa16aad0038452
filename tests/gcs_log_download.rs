//! Logs on the vehicle, fetched as ground stations fetch them: the one pymavlink script
//! tests/python/gcs_logs.py flies a short flight on `kestrel run` (and on ArduCopter SITL when
//! `KESTREL_ARDUCOPTER` names it, see tests/support/arducopter.rs), then lists and downloads the
//! flight's log (LOG_REQUEST_LIST / LOG_REQUEST_DATA) and uses MAVLink FTP (pymavlink's mavftp):
//! the root and `/logs` listings, `@PARAM/param.pck`, a CRC and a write.
//!
//! Kestrel must: refuse a list while armed with ArduPilot's "Disarm for log download"; list the
//! flight's log (ids from 1, `last_log_num` the last id, its size and time); send it in 90-byte
//! LOG_DATA chunks that put together equal the file on disk byte for byte and open with the
//! Python `mcap` reader, the log starting armed and ending disarmed; answer a request at the end
//! with one zero-length chunk; give in `param.pck` the same parameters with the same values as
//! PARAM_REQUEST_LIST; give the log's CRC as ArduPilot computes it; refuse a write as a
//! read-only file system (FailErrno, EROFS).
//!
//! ArduCopter answers the list, the download and FTP the same way (its root lists `logs` and
//! not `@PARAM`, whose `param.pck` is reached by name; so does ours). Where they differ, on
//! purpose: its logs are DataFlash `.BIN`, ours MCAP (what `kestrel report` and Foxglove read);
//! its SD card is writable, so a CreateFile succeeds there; its parameter set is its own; it
//! keeps logging for a moment after disarming, so its log outgrows the size listed just after.
//! The ArduCopter half downloads only the first 64 kB of its log (its logs are megabytes).

mod support;
use support::{arducopter, sim_vehicle};

use std::time::Instant;

use serde_json::Value;
use sim_vehicle::{scripted_session, session_link, sim_config, temp_dir};

const SCRIPT: &str = "gcs_logs.py";

/// EROFS, Linux's "read-only file system", with MAV_FTP_ERR_FAILERRNO (2).
const READ_ONLY_NAK: [u64; 2] = [2, 30];

fn results(v: &Value) -> &Value {
    let r = &v["results"];
    assert!(r.is_object(), "no results in {v:#}");
    r
}

#[test]
fn a_flights_log_lists_downloads_byte_for_byte_and_ftp_serves_logs_and_params_as_arducopter() {
    let started = Instant::now();
    let dir = temp_dir("log-download");
    let log_dir = dir.join("logs");
    let env = [("LOG_DIR", log_dir.display().to_string())];
    let kestrel = scripted_session(&dir, "log-download", SCRIPT, &env, |port| {
        let graph = sim_config(&session_link(port, &dir));
        assert!(graph.contains("dir = \"sim/logs\""), "config/sim.toml's [record] dir");
        graph.replace("dir = \"sim/logs\"", &format!("dir = \"{}\"", log_dir.display()))
    });
    println!("kestrel half: {:.1} s", started.elapsed().as_secs_f64());
    let ours = results(&kestrel);

    // Armed: nothing listed, ArduPilot's words said.
    assert_eq!(ours["armed_list"]["entries"], 0, "{ours:#}");
    let said = ours["armed_list"]["said"].as_array().expect("texts");
    assert!(said.iter().any(|t| t == "Disarm for log download"), "{said:?}");

    // One flight, one log: id 1 of 1, its size and time set.
    let entries = ours["entries"].as_array().expect("entries");
    assert_eq!(entries.len(), 1, "{entries:?}");
    let entry = &entries[0];
    assert_eq!(
        (entry["id"].as_u64(), entry["num_logs"].as_u64(), entry["last_log_num"].as_u64()),
        (Some(1), Some(1), Some(1))
    );
    assert_eq!(entry["time_utc_set"], true);
    let size = entry["size"].as_u64().expect("size");
    assert!(size > 10_000, "a flight's log is more than a header: {size} bytes");

    // The download is the file on disk, byte for byte, and opens with the `mcap` reader.
    let download = &ours["download"];
    assert_eq!(download["bytes"].as_u64(), Some(size));
    assert_eq!(download["chunk_sizes_max"], 90);
    assert_eq!(download["past_end"], serde_json::json!([size, 0]), "one zero-length chunk at the end");
    let disk = &ours["on_disk"];
    assert_eq!(
        (disk["file"].as_str(), disk["logs"].as_u64(), &disk["equal"]),
        (Some("00000001.mcap"), Some(1), &Value::Bool(true)),
        "{disk:#}"
    );
    assert!(disk["topics"].as_u64().is_some_and(|n| n > 10), "{disk:#}");
    assert_eq!(
        (&disk["first_armed"], &disk["last_armed"]),
        (&Value::Bool(true), &Value::Bool(false)),
        "the log is the armed flight: {disk:#}"
    );

    // FTP: the two directories, the log, every parameter as PARAM_REQUEST_LIST gives it.
    let ftp = &ours["ftp"];
    let root: Vec<&str> =
        ftp["/"]["entries"].as_array().expect("root").iter().filter_map(|e| e[0].as_str()).collect();
    assert_eq!(root, ["logs"], "{ftp:#}");
    let logs = ftp["/logs"]["entries"].as_array().expect("logs");
    assert_eq!(logs.len(), 1, "{ftp:#}");
    assert_eq!((logs[0][0].as_str(), logs[0][2].as_u64()), (Some("00000001.mcap"), Some(size)));
    let pck = &ftp["param_pck"];
    assert_eq!(pck["count"], ours["params"]["count"], "{ftp:#}");
    assert!(pck["count"].as_u64().is_some_and(|n| n > 50), "the graph's parameters: {ftp:#}");
    assert_eq!(
        (&pck["same_names"], &pck["same_values"]),
        (&Value::Bool(true), &Value::Bool(true)),
        "{ftp:#}"
    );
    assert_eq!(ftp["crc_equal"], true, "{ftp:#}");
    assert_eq!(ftp["create_file"], serde_json::json!(["NAK", READ_ONLY_NAK]), "{ftp:#}");
    assert!(!log_dir.join("kestrel-write-test.txt").exists());

    let Some(binary) = arducopter::binary() else { return };
    let sitl_started = Instant::now();
    let ardu = arducopter::scripted_session(&binary, SCRIPT, &[("DOWNLOAD_LIMIT", "65536".to_owned())]);
    println!("ArduCopter half: {:.1} s", sitl_started.elapsed().as_secs_f64());
    let theirs = results(&ardu);
    // The same refusal while armed, the same LOG_ENTRY and LOG_DATA shapes.
    assert_eq!(theirs["armed_list"]["entries"], ours["armed_list"]["entries"], "{theirs:#}");
    assert!(
        theirs["armed_list"]["said"]
            .as_array()
            .expect("texts")
            .iter()
            .any(|t| t == "Disarm for log download"),
        "{theirs:#}"
    );
    let last = theirs["entries"].as_array().and_then(|e| e.last()).expect("ArduCopter's entries");
    assert_eq!(last["id"], last["last_log_num"], "{theirs:#}");
    assert_eq!(last["time_utc_set"], entry["time_utc_set"], "{theirs:#}");
    assert_eq!(theirs["download"]["chunk_sizes_max"], download["chunk_sizes_max"], "{theirs:#}");
    // Not compared: a request at the listed end. ArduCopter keeps writing its log for a moment
    // after disarming (a list taken then is already short of the file), so it answers with data.
    println!("ArduCopter's answer at its listed end: {}", theirs["download"]["past_end"]);
    // FTP: both list a log directory and serve a param.pck that decodes to the listed set.
    let their_ftp = &theirs["ftp"];
    assert_eq!(their_ftp["/logs"]["error"], ftp["/logs"]["error"], "{their_ftp:#}");
    assert_eq!(their_ftp["param_pck"]["count"], theirs["params"]["count"], "{their_ftp:#}");
    assert_eq!(their_ftp["param_pck"]["same_names"], true, "{their_ftp:#}");
    println!("ArduCopter's answer to CreateFile (a writable SD card): {}", their_ftp["create_file"]);
    let _ = std::fs::remove_dir_all(&dir);
    println!("whole test: {:.1} s", started.elapsed().as_secs_f64());
}
