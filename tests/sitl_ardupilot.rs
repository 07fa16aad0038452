//! ArduCopter SITL flying on Kestrel's physics (`kestrel sitl ardupilot`, the simulator as
//! ArduPilot's JSON physics backend), checked on what ArduCopter reports over MAVLink and on
//! what Kestrel's simulator saw. Skipped, with a message, when `KESTREL_ARDUCOPTER` is unset
//! (tests/support/arducopter.rs).
//!
//! * The square: armed in GUIDED, a take-off to 10 m, config/missions/square.plan in AUTO and its
//!   RTL, landed within 2 m of home, in lockstep, in under a minute of wall time.
//! * Hover throttle: the same square on Kestrel's physics and on ArduCopter's own multicopter
//!   physics (`--model x`, the X layout of `--model +`, to match FRAME_TYPE 1) given the same
//!   mass, inertia and thrust curve (config/ardupilot/quad-x-frame.json: thrust linear in the
//!   pulse over 1000..2000 µs, hovering at 0.3343 of it, as the vehicle file's motors); the
//!   MOT_THST_HOVER each teaches ArduCopter in flight agree within 10 %.

mod support;
use support::{arducopter, sim_vehicle};

use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;
use sim_vehicle::{Proc, python_client, root, stop, tail, temp_dir, transcript_until_exit};

const SCRIPT: &str = "ardupilot_square.py";
/// Wall time the square may take, SITL's boot and EKF3's GPS wait included.
const SQUARE_WALL_LIMIT: Duration = Duration::from_secs(60);

/// What one flight reported: the client's last line and, on Kestrel's physics, the simulator's
/// summary.
struct Flight {
    client: Value,
    physics: Option<Value>,
    wall_s: f64,
}

/// Flies the client with `env` against ArduCopter SITL on Kestrel's physics
/// (`kestrel sitl ardupilot`), then stops it and reads its summary.
fn on_kestrel_physics(binary: &Path, env: &[(&str, String)], limit: Duration, label: &str) -> Flight {
    let (mut client, lines) = python_client(SCRIPT, |c| c.envs(env.iter().map(|(k, v)| (k, v))));
    let first = lines.recv_timeout(Duration::from_secs(15)).unwrap_or_default();
    let port: u16 = first.strip_prefix("PORT ").and_then(|p| p.trim().parse().ok()).expect("client port");
    let started = Instant::now();
    let (instance, _lock) = arducopter::free_instance();
    let dir = temp_dir(&format!("ardupilot-sitl-{label}"));
    let summary_path = dir.join("summary.json");
    let log_path = dir.join("kestrel.log");
    let log = File::create(&log_path).expect("log");
    let mut kestrel = Proc(
        Command::new(env!("CARGO_BIN_EXE_kestrel"))
            .args(["sitl", "ardupilot", "--config"])
            .arg(root().join("config/ardupilot/sitl.toml"))
            .args(["--gcs", &format!("udpclient:127.0.0.1:{port}"), "--instance", &instance.to_string()])
            .arg("--summary")
            .arg(&summary_path)
            .arg("--dir")
            .arg(dir.join("sitl"))
            .env(arducopter::ENV, binary)
            .stdin(Stdio::null())
            .stdout(log.try_clone().expect("log"))
            .stderr(log)
            .spawn()
            .expect("start kestrel sitl ardupilot"),
    );
    println!("── {SCRIPT} ({label}) against ArduCopter SITL instance {instance} on Kestrel's physics ──");
    let (exit, transcript) = transcript_until_exit(&mut client, &lines, || {
        started.elapsed() > limit || kestrel.0.try_wait().ok().flatten().is_some()
    });
    let wall_s = started.elapsed().as_secs_f64();
    let sitl_log = || {
        format!(
            "kestrel:\n{}\nSITL:\n{}",
            tail(&std::fs::read_to_string(&log_path).unwrap_or_default(), 20),
            tail(&std::fs::read_to_string(dir.join("sitl/arducopter.log")).unwrap_or_default(), 30)
        )
    };
    assert!(
        exit.is_some_and(|s| s.success()),
        "{label}: client {exit:?} after {wall_s:.1} s\n{}",
        sitl_log()
    );
    let status = stop(&mut kestrel, label);
    assert!(status.success(), "{label}: kestrel sitl ardupilot {status}\n{}", sitl_log());
    let physics: Value = serde_json::from_str(&std::fs::read_to_string(&summary_path).expect("summary"))
        .expect("summary JSON");
    println!("{label}: {wall_s:.1} s of wall time; Kestrel's physics: {physics}");
    let _ = std::fs::remove_dir_all(&dir);
    Flight { client: last_json(&transcript, label), physics: Some(physics), wall_s }
}

/// The same client against ArduCopter on its own physics `model` with `parms`.
fn on_own_physics(
    binary: &Path,
    env: &[(&str, String)],
    frame: &str,
    frame_json: &Path,
    parms: &[&Path],
    label: &str,
) -> Flight {
    let (mut client, lines) = python_client(SCRIPT, |c| c.envs(env.iter().map(|(k, v)| (k, v))));
    let first = lines.recv_timeout(Duration::from_secs(15)).unwrap_or_default();
    let port: u16 = first.strip_prefix("PORT ").and_then(|p| p.trim().parse().ok()).expect("client port");
    let started = Instant::now();
    let mut sitl = arducopter::ArduCopter::start_model(binary, port, frame, Some(frame_json), parms);
    println!(
        "── {SCRIPT} ({label}) against ArduCopter SITL instance {} on --model {frame} ──",
        sitl.instance
    );
    let (exit, transcript) = transcript_until_exit(&mut client, &lines, || {
        started.elapsed() > Duration::from_secs(120) || !sitl.running()
    });
    let wall_s = started.elapsed().as_secs_f64();
    assert!(exit.is_some_and(|s| s.success()), "{label}: client {exit:?}\nSITL:\n{}", sitl.log_tail(30));
    println!("{label}: {wall_s:.1} s of wall time");
    Flight { client: last_json(&transcript, label), physics: None, wall_s }
}

fn last_json(transcript: &[String], label: &str) -> Value {
    let last = transcript.last().unwrap_or_else(|| panic!("{label}: no result line"));
    serde_json::from_str(last)
        .unwrap_or_else(|e| panic!("{label}: the last line is no JSON result ({e}): {last}"))
}

fn plan() -> (&'static str, String) {
    ("PLAN", root().join("config/missions/square.plan").display().to_string())
}

fn number(v: &Value, what: &str) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("{what} is no number: {v}"))
}

#[test]
fn arducopter_on_kestrels_physics_flies_the_square_and_lands_home_within_a_minute() {
    let Some(binary) = arducopter::binary() else { return };
    let flight = on_kestrel_physics(
        &binary,
        &[plan(), ("DEADLINE_S", SQUARE_WALL_LIMIT.as_secs().to_string())],
        SQUARE_WALL_LIMIT,
        "square",
    );
    let r = &flight.client["results"];
    // What ArduCopter reported over MAVLink.
    assert!(number(&r["max_rel_alt_m"], "max_rel_alt_m") >= 9.5, "{r:#}");
    // Items 1 (take-off) to 5 (the square's corners) each reached, or left for the next one
    // (MISSION_CURRENT; either datagram may be lost to a client at many times real time).
    let seqs =
        |key: &str| -> Vec<u64> { r[key].as_array().expect(key).iter().filter_map(Value::as_u64).collect() };
    let (reached, currents) = (seqs("reached"), seqs("mission_currents"));
    for seq in 1..=5 {
        assert!(reached.contains(&seq) || currents.contains(&(seq + 1)), "item {seq} never flown: {r:#}");
    }
    let modes: Vec<&str> = r["modes"].as_array().expect("modes").iter().filter_map(Value::as_str).collect();
    for mode in ["GUIDED", "AUTO"] {
        assert!(modes.contains(&mode), "{mode} never flown: {r:#}");
    }
    let from_home_m = number(&r["landed_from_home_m"], "landed_from_home_m");
    assert!(from_home_m < 2.0, "landed {from_home_m} m from home: {r:#}");
    // What Kestrel's simulator saw of the same flight.
    let p = flight.physics.as_ref().expect("physics summary");
    assert_eq!(p["collisions"], 0, "{p:#}");
    assert_eq!(p["crashed"], false, "{p:#}");
    assert_eq!(p["landed"], true, "{p:#}");
    assert_eq!(p["refused_pulses"], 0, "{p:#}");
    assert_eq!(p["refused_packets"], 0, "{p:#}");
    let [n, e] = [0, 1].map(|i| number(&p["position_ned_m"][i], "position_ned_m"));
    assert!(n.hypot(e) < 2.0, "the simulator has it {:.2} m from home: {p:#}", n.hypot(e));
    println!(
        "square on Kestrel's physics: {:.1} s wall, {} s simulated flight, landed {from_home_m} m from home \
         (truth {:.2} m), least clearance {}, hover throttle {}",
        flight.wall_s,
        r["flight_s"],
        n.hypot(e),
        p["least_clearance_m"],
        r["hover_throttle"]
    );
    assert!(flight.wall_s < SQUARE_WALL_LIMIT.as_secs_f64(), "{:.1} s of wall time", flight.wall_s);
}

#[test]
fn hover_throttle_on_kestrels_physics_is_within_ten_percent_of_arducopters_own_physics() {
    let Some(binary) = arducopter::binary() else { return };
    let env = [plan(), ("DEADLINE_S", "110".to_string())];
    let kestrel = on_kestrel_physics(&binary, &env, Duration::from_secs(120), "square, Kestrel's physics");
    let parm: PathBuf = root().join("config/ardupilot/quad-x.parm");
    let frame = root().join("config/ardupilot/quad-x-frame.json");
    let own = on_own_physics(&binary, &env, "x", &frame, &[&parm], "square, --model x");
    let hover = |f: &Flight| number(&f.client["results"]["hover_throttle"], "hover_throttle");
    let (k, a) = (hover(&kestrel), hover(&own));
    println!(
        "MOT_THST_HOVER learned: {k:.4} on Kestrel's physics ({:.1} s wall), {a:.4} on --model x ({:.1} s wall): {:+.1} %",
        kestrel.wall_s,
        own.wall_s,
        100.0 * (k - a) / a
    );
    // Both learned: each moved well away from copter.parm's starting 0.39, so their agreement
    // says something about the physics.
    for (name, value) in [("Kestrel's physics", k), ("--model x", a)] {
        assert!((value - 0.39).abs() > 0.05, "{name}: MOT_THST_HOVER {value} barely moved from 0.39");
    }
    assert!((k - a).abs() <= 0.1 * a, "hover throttle {k} on Kestrel's physics vs {a} on ArduCopter's own");
}
