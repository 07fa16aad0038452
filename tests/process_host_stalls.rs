//! The default graph on the wall clock, with the whole process stopped (SIGSTOP) for 150 ms
//! every 1.5 s while it flies the 40 m leg: a non-realtime host that does not run the flight
//! process for a while, as a loaded CI host did to the Zenoh split's flight side (its control
//! loop went up to 95 ms between iterations, and it landed mid-mission on a stale navigation
//! state). Every thread stops at once and wakes to a clock that moved on, so the commander may
//! run before the estimator has published again.
//!
//! The controller flies blind through such a gap and the commander lands only once the state
//! has been stale for `failsafe.nav_stale_s` (1 s, PX4's `COM_POS_FS_DELAY`). With that set to
//! 0 (a stale state landed at once before) the same stalls landed the vehicle mid-mission in
//! each of four runs (the failsafe fired 13.1 to 26.2 s into the run): a stall leaves the
//! commander without a fresh state only when it runs before the estimator, so that check is
//! left to the commander's tests (actors/control/tests/failsafes.rs), which time the gap
//! exactly.

mod support;
use support::flights;

use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::thread::sleep;
use std::time::Duration;

use flights::{collisions, merged_graph, repo, scratch};
use serde_json::Value;

/// How long each stall lasts, and how long the process runs between two.
const STALL: Duration = Duration::from_millis(150);
const BETWEEN: Duration = Duration::from_millis(1500);

/// `config/sim.toml` (its bases merged in) on the realtime clock, runnable from `dir` (absolute
/// paths, the MAVLink link on an ephemeral local port).
fn realtime_graph(dir: &Path) -> PathBuf {
    let config_dir = repo().join("config");
    let text = merged_graph("sim.toml");
    let lockstep = "clock = \"lockstep\"";
    assert!(text.contains(lockstep), "the stock graph changed");
    let text = text
        .replace(lockstep, "clock = \"realtime\"")
        .replace("\"worlds/", &format!("\"{}/worlds/", config_dir.display()))
        .replace("\"vehicles/", &format!("\"{}/vehicles/", config_dir.display()));
    let graph = dir.join("graph.toml");
    std::fs::write(&graph, text).unwrap();
    graph
}

fn signal(child: &Child, signal: &str) -> bool {
    Command::new("kill").args([signal, &child.id().to_string()]).status().is_ok_and(|s| s.success())
}

/// Flies the 40 m leg on `graph`, stopping the process as the module says until it exits;
/// returns the report and the number of stalls.
fn fly_with_stalls(name: &str, graph: &Path) -> (Value, u32) {
    let report = graph.with_file_name("report.json");
    let mut child = Command::new(env!("CARGO_BIN_EXE_kestrel"))
        .current_dir(graph.parent().unwrap())
        .env_remove("RUST_LOG")
        .args(["run", "--quiet", "--auto", "--exit-on-land", "--duration", "120", "--config"])
        .arg(graph)
        .arg("--mission")
        .arg(repo().join("config/missions/leg-40m.plan"))
        .arg("--report")
        .arg(&report)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("kestrel runs");
    let mut stalls = 0;
    loop {
        sleep(BETWEEN);
        if child.try_wait().unwrap().is_some() || !signal(&child, "-STOP") {
            break;
        }
        sleep(STALL);
        assert!(signal(&child, "-CONT"), "{name}: the process was stopped and could not be continued");
        stalls += 1;
    }
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{name}: {}", String::from_utf8_lossy(&out.stderr));
    let report = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    (report, stalls)
}

#[test]
fn a_flight_process_stopped_150_ms_every_1_5_s_flies_its_mission() {
    let dir = scratch("host-stalls", "flight");
    let (report, stalls) = fly_with_stalls("stalled", &realtime_graph(&dir));
    let _ = std::fs::remove_dir_all(&dir);
    let period_max_ms = report["control"]["period_max_us"].as_f64().unwrap_or(f64::NAN) / 1e3;
    println!(
        "figure: host stalls ({} ms every {} ms): {stalls} stalls, mission {}, failsafes {}, collisions {}, control period max {period_max_ms:.1} ms",
        STALL.as_millis(),
        BETWEEN.as_millis(),
        report["mission"],
        report["failsafes"],
        report["flight"]["collisions"],
    );
    assert!(stalls >= 8, "the leg takes some 25 s: {stalls} stalls");
    assert!(period_max_ms >= STALL.as_secs_f64() * 1e3, "the loop saw the stalls: {report:#}");
    assert_eq!(report["mission"]["completed"], true, "{report:#}");
    assert_eq!(report["failsafes"], serde_json::json!([]), "{report:#}");
    assert_eq!(collisions(&report), 0);
    assert_eq!(report["flight"]["crashed"], false);
}
