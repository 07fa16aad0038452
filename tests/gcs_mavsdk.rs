//! With a client we did not write: MAVSDK (PyPI `mavsdk`, whose wheel
//! carries the C++ MAVSDK core) flies `kestrel run` on the default config, unchanged, over
//! MAVSDK's default connection `udpin://0.0.0.0:14540` (tests/python/mavsdk_flight.py).
//!
//! The default config sends from fixed local ports (18570 and 14580) to fixed ones (14550 and
//! 14540), exactly as PX4 SITL does, so two such vehicles on one loopback would hear each other's
//! clients. Each scenario therefore runs in a network namespace of its own (`unshare --net`,
//! through a user namespace, which needs no root), with a loopback of its own: the ports are the
//! test's alone while the rest of the suite runs beside it. The vehicle runs at `--speedup 2`
//! (MAVSDK's timers are wall-clock, and a GCS heartbeat every 2 vehicle seconds is well inside
//! the 5 s link-loss timeout). A scenario passes when the client exits 0 — every check it makes
//! is on what MAVSDK reports — and `kestrel` then stops cleanly on SIGTERM.

mod support;
use support::sim_vehicle;

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use sim_vehicle::{Proc, python, root, tail, temp_dir};

/// Simulated seconds per wall second (`kestrel run --speedup`).
const SPEEDUP: &str = "2";
/// Wall-clock bound on one scenario.
const LIMIT: Duration = Duration::from_secs(240);

/// Runs `mavsdk_flight.py scenario args` beside `kestrel run` in a fresh network namespace and
/// returns the client's transcript.
fn fly(scenario: &str, args: &[&str]) -> Vec<String> {
    let dir = temp_dir(&format!("mavsdk-{scenario}"));
    let log = dir.join("kestrel.log");
    // In the namespace: loopback up, the vehicle in the background, the client in front; then
    // SIGTERM to the vehicle as an operator stops it, and both exit codes on the last line.
    let script = r#"
        ip link set lo up || exit 90
        "$KESTREL" run --speedup "$KESTREL_SPEEDUP" --duration 900 --quiet > "$KESTREL_LOG" 2>&1 &
        vehicle=$!
        "$PYTHON" "$CLIENT" "$@"
        client=$?
        kill -TERM $vehicle 2>/dev/null
        wait $vehicle
        echo "EXIT client=$client kestrel=$?"
    "#;
    let mut child = Proc(
        Command::new("unshare")
            .args(["--net", "--map-root-user", "sh", "-c", script, "sh", scenario])
            .args(args)
            .env("KESTREL", env!("CARGO_BIN_EXE_kestrel"))
            .env("KESTREL_LOG", &log)
            .env("KESTREL_SPEEDUP", SPEEDUP)
            // The vehicle's own logs (config/sim.toml's `[record] dir`) stay in the scenario's dir.
            .env("KESTREL_STATE_DIR", &dir)
            .env("PYTHON", python())
            .env("CLIENT", root().join("tests/python/mavsdk_flight.py"))
            .env("PYTHONUNBUFFERED", "1")
            .env("PYTHONDONTWRITEBYTECODE", "1")
            .env_remove("RUST_LOG")
            .current_dir(&dir)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("unshare (util-linux) runs the scenario in a network namespace of its own"),
    );
    let stdout = child.0.stdout.take().expect("stdout");
    let (tx, lines) = std::sync::mpsc::channel::<String>();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    println!("── mavsdk {scenario} {} ──", args.join(" "));
    let started = Instant::now();
    let mut transcript = Vec::new();
    let finished = loop {
        while let Ok(line) = lines.recv_timeout(Duration::from_millis(100)) {
            println!("  {line}");
            transcript.push(line);
        }
        if child.0.try_wait().expect("status").is_some() {
            while let Ok(line) = lines.recv_timeout(Duration::from_millis(200)) {
                println!("  {line}");
                transcript.push(line);
            }
            break true;
        }
        if started.elapsed() > LIMIT {
            break false;
        }
    };
    let mut stderr = String::new();
    if let Some(mut pipe) = child.0.stderr.take() {
        let _ = std::io::Read::read_to_string(&mut pipe, &mut stderr);
    }
    let kestrel_log = std::fs::read_to_string(&log).unwrap_or_default();
    let last = transcript.last().cloned().unwrap_or_default();
    assert!(
        finished && last == "EXIT client=0 kestrel=0",
        "mavsdk {scenario}: {} after {:.0} s\nclient stderr:\n{}\nkestrel log (tail):\n{}",
        if finished { last } else { "ran past its time limit".to_owned() },
        started.elapsed().as_secs_f64(),
        tail(&stderr, 30),
        tail(&kestrel_log, 40)
    );
    println!("── mavsdk {scenario}: passed in {:.1} s ──", started.elapsed().as_secs_f64());
    transcript
}

/// The figure a step logged (`wall_s step: detail`), for the closing note.
fn detail<'a>(transcript: &'a [String], step: &str) -> &'a str {
    transcript
        .iter()
        .find_map(|l| l.split_once(&format!(" {step}: ")).map(|(_, d)| d))
        .unwrap_or_else(|| panic!("no `{step}` step in {transcript:?}"))
}

#[test]
fn mavsdk_arms_takes_off_to_8_m_and_lands() {
    let t = fly("takeoff_land", &[]);
    println!("altitude reached: {}; hover: {}", detail(&t, "altitude"), detail(&t, "hover"));
}

#[test]
fn mavsdk_imports_uploads_downloads_and_flies_a_qgroundcontrol_plan() {
    let plan = root().join("config/missions/square.plan");
    let t = fly("mission", &[plan.to_str().expect("utf-8 path")]);
    println!("download: {}; landed: {}", detail(&t, "download"), detail(&t, "landed"));
}

#[test]
fn mavsdk_offboard_velocity_flies_a_10_m_square_then_a_body_velocity_circle_of_radius_v_over_omega() {
    let t = fly("offboard", &[]);
    println!("square: {}; circle: {}", detail(&t, "square"), detail(&t, "circle"));
}

#[test]
fn mavsdk_goto_location_hold_orbit_and_return_to_launch() {
    let t = fly("goto_hold_rtl", &[]);
    println!(
        "hold: {}; orbit: {}; landed: {}",
        detail(&t, "hold"),
        detail(&t, "orbit"),
        detail(&t, "landed")
    );
}

#[test]
fn mavsdk_log_files_lists_and_downloads_the_flights_log_as_it_is_on_the_vehicle() {
    let t = fly("log_files", &[]);
    println!(
        "entries: {}; download: {}; mcap: {}",
        detail(&t, "entries"),
        detail(&t, "download"),
        detail(&t, "mcap")
    );
}

#[test]
fn mavsdk_failure_plugin_gps_off_is_denied_until_enabled_then_lands_as_the_fault_matrix_says() {
    let t = fly("failure_gps", &[]);
    println!("disabled: {}; land: {}", detail(&t, "disabled"), detail(&t, "land"));
}

#[test]
fn mavsdk_geofence_upload_refuses_a_goto_outside_and_a_breach_returns() {
    let t = fly("geofence", &[]);
    println!("outside: {}; breach: {}", detail(&t, "goto_location outside"), detail(&t, "breach"));
}

#[test]
fn mavsdk_follow_me_starts_follow_and_the_vehicle_keeps_its_place_behind_a_walking_target() {
    let t = fly("follow_me", &[]);
    println!("plugin: {}; follow: {}", detail(&t, "set_target_location in FOLLOW"), detail(&t, "follow"));
}
