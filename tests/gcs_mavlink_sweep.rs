//! A sweep of bad input: `scripts/mavlink_sweep.py` throws 10⁵ datagrams of bad MAVLink
//! (random bytes; valid-CRC v1, v2 and signed frames of every message id with random and extreme
//! fields; truncated and oversized frames; frames claiming the vehicle's own system id; every
//! COMMAND_LONG and COMMAND_INT id with random and extreme parameters) at `kestrel run` on the
//! simulator, over UDP loopback, and checks what a ground station sees during and after it; then,
//! once the vehicle has stopped, what its report, log and flight record hold. The script's module
//! doc says what is sent, what is left out and why, and what each check means.
//!
//! The vehicle runs config/sim.toml with one link endpoint, a UDP server on an ephemeral port of
//! 127.0.0.1 (read back from the log, so parallel tests never collide), the ground-station
//! parameter table of tests/gcs_pymavlink.rs, and `[record] topics` cut to what `--check-run` reads.
//! It is paced at `--speedup 1`: a flood of 2500 datagrams per wall second is one per vehicle
//! second too.

mod support;
use support::sim_vehicle;

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;
use sim_vehicle::{PARAM_TABLE, Proc, python, root, sim_config, stop, tail, temp_dir};

/// Datagrams in the sweep, and the seed that makes them.
/// `KESTREL_SWEEP_FRAMES` overrides the count for the long bench run (10⁶: `KESTREL_SWEEP_FRAMES=1000000
/// cargo nextest run -p kestrel --test gcs_mavlink_sweep --no-capture`), with the run's bound scaled.
const FRAMES: &str = "100000";
/// The script's default rate (datagrams per second), which sets how long a sweep lasts.
const RATE_HZ: u64 = 2500;
const SEED: &str = "14";
/// Vehicle seconds (`--duration`; wall seconds too at `--speedup 1`) beyond the sweep itself that
/// bound the run: start-up, the parameter lists before and after, the stop.
const MARGIN_S: u64 = 200;
/// `[record] topics` in config/sim.toml, and what the sweep records instead: the simulator's
/// truth and the supervisor's actor failures, which the script's `--check-run` reads.
const RECORD_ALL: &str = "topics = [\"*\"]";
const RECORD_TRUTH: &str = "topics = [\"ground_truth\", \"supervisor\"]";

/// The UDP server's port, from kestrel's "MAVLink endpoint open … local=Some(127.0.0.1:PORT)".
fn server_port(log: &Path) -> u16 {
    let started = Instant::now();
    loop {
        let text = std::fs::read_to_string(log).unwrap_or_default();
        let port = text
            .lines()
            .filter(|l| l.contains("MAVLink endpoint open") && l.contains("udp server"))
            .find_map(|l| l.split("local=Some(127.0.0.1:").nth(1)?.split(')').next()?.parse().ok());
        if let Some(port) = port {
            return port;
        }
        assert!(started.elapsed() < Duration::from_secs(30), "no UDP server opened:\n{}", tail(&text, 20));
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Runs scripts/mavlink_sweep.py with `args` and returns its last line as JSON, echoing its
/// output for `--nocapture`.
fn sweep_script(args: &[&str]) -> Value {
    let Output { stdout, stderr, .. } = Command::new(python())
        .arg(root().join("scripts/mavlink_sweep.py"))
        .args(args)
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .stdin(Stdio::null())
        .output()
        .expect("start scripts/mavlink_sweep.py");
    let mut last = String::new();
    for line in BufReader::new(&stdout[..]).lines().map_while(Result::ok) {
        println!("  {line}");
        last = line;
    }
    serde_json::from_str(&last).unwrap_or_else(|e| {
        panic!(
            "mavlink_sweep.py {args:?} printed no JSON result ({e}):\n{}",
            String::from_utf8_lossy(&stderr)
        )
    })
}

/// `"name: detail"` for every check of `result` that did not pass (the script's own failure, such
/// as no heartbeat at all, when it ran none).
fn failed_checks(result: &Value) -> Vec<String> {
    let Some(checks) = result["checks"].as_object() else {
        return vec![format!("no checks run: {result}")];
    };
    checks
        .iter()
        .filter(|(_, c)| c["pass"] != Value::Bool(true))
        .map(|(name, c)| format!("{name}: {c}"))
        .collect()
}

#[test]
fn a_sweep_of_bad_mavlink_leaves_the_vehicle_up_unarmed_unmoved_and_unchanged() {
    let frames = std::env::var("KESTREL_SWEEP_FRAMES").unwrap_or_else(|_| FRAMES.to_owned());
    let count: u64 = frames.parse().expect("KESTREL_SWEEP_FRAMES is a count");
    let duration_s = (count / RATE_HZ + MARGIN_S).to_string();
    let dir = temp_dir("mavlink-sweep");
    let link = format!(
        "params.system_id = 1\n\
         params.endpoints = [ {{ type = \"udp_in\", bind = \"127.0.0.1:0\" }} ]\n\
         params.params = {PARAM_TABLE}\n"
    );
    let config_text = sim_config(&link);
    assert!(config_text.contains(RECORD_ALL), "config/sim.toml records no {RECORD_ALL}");
    let config = dir.join("sweep.toml");
    std::fs::write(&config, config_text.replace(RECORD_ALL, RECORD_TRUTH)).expect("write the config");
    let (report, record, log_path) =
        (dir.join("report.json"), dir.join("truth.mcap"), dir.join("kestrel.log"));
    let log = std::fs::File::create(&log_path).expect("log file");
    let mut kestrel = Proc(
        Command::new(env!("CARGO_BIN_EXE_kestrel"))
            .current_dir(&dir)
            .env_remove("RUST_LOG")
            .args(["run", "--quiet", "--speedup", "1", "--duration", &duration_s, "--config"])
            .arg(&config)
            .arg("--report")
            .arg(&report)
            .arg("--record")
            .arg(&record)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(log)
            .spawn()
            .expect("start kestrel run"),
    );
    let target = format!("udp:127.0.0.1:{}", server_port(&log_path));
    println!("── sweep of {frames} datagrams (seed {SEED}) at {target} ──");
    let during = sweep_script(&["--frames", &frames, "--seed", SEED, "--target", &target]);
    let up = kestrel.0.try_wait().expect("kestrel status").is_none();

    let status = stop(&mut kestrel, "mavlink sweep");
    let kestrel_log = std::fs::read_to_string(&log_path).unwrap_or_default();
    let mut failed = failed_checks(&during);
    if up {
        if !status.success() {
            failed.push(format!("clean_exit: kestrel exited with {status} on SIGTERM"));
        }
        println!("── after the run: {} ──", report.display());
        let files = [&report, &record, &log_path].map(|p| p.to_str().expect("utf-8 path"));
        let after =
            sweep_script(&["--check-run", "--report", files[0], "--record", files[1], "--log", files[2]]);
        failed.extend(failed_checks(&after));
    } else {
        // Its report and record may be unfinished: nothing more to read.
        failed.push(format!("process_up: kestrel exited during the sweep with {status}"));
    }
    assert!(
        failed.is_empty(),
        "the sweep found holes:\n  {}\nevidence: {}\nkestrel log (tail):\n{}",
        failed.join("\n  "),
        during["evidence"],
        tail(&kestrel_log, 20)
    );
    std::fs::remove_dir_all(&dir).ok();
}
