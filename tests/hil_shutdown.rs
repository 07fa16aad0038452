//! Stopping the process never drops a flying vehicle: the Navio2 graph (`config/navio2.toml`,
//! realtime, the real drivers) flies config/missions/square.plan with `--hil` against the
//! emulated board, and at 10 m a SIGTERM, SIGHUP or SIGINT arrives, as from `systemctl stop`, a
//! dropped SSH session or Ctrl-C. Each must land the vehicle under power and only then end the
//! process, with exit status 0 (`kestrel::shutdown`).
//!
//! What is checked, from the run's own recording and report:
//! * the commander switched to LAND with the notice "shutdown requested: landing";
//! * from the signal to touchdown the controller kept the motors armed and spinning (every
//!   `actuator_outputs` armed, the mean command above a descent's), and the simulated vehicle
//!   came down at a landing's speed (never faster than 2.5 m/s, touching down slower than
//!   1 m/s), intact and without collision;
//! * the process ended only after the disarm, by itself.
//!
//! Realtime, so each flight runs alone (`.config/nextest.toml`, as tests/hil_flight.rs).

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use kestrel::recorder::LogReader;
use kestrel_proto::messages::{ActuatorOutputs, FlightMode, GroundTruth, VehicleStatus};

/// Height above home at which the signal is sent (m): the square's take-off height is 10 m.
const SIGNAL_AT_ALT_M: f64 = 9.0;

struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        if let Ok(None) = self.0.try_wait() {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
}

/// `alt 9.8 m` and `flying` from a status line, as the height it shows.
fn flying_alt(line: &str) -> Option<f64> {
    if !line.contains("armed") || !line.contains("vehicle flying") {
        return None;
    }
    let rest = &line[line.find(" alt ")? + 5..];
    rest.split_whitespace().next()?.parse().ok()
}

fn lands_on(signal: &str) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir: PathBuf =
        std::env::temp_dir().join(format!("kestrel-hil-shutdown-{}-{signal}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch dir");
    let (record, report_path) = (dir.join("flight.mcap"), dir.join("report.json"));
    let mut kestrel = Killed(
        Command::new(env!("CARGO_BIN_EXE_kestrel"))
            .current_dir(root)
            .args(["run", "--config", "config/navio2.toml", "--hil", "--auto", "--duration", "300"])
            .args(["--mission", "config/missions/square.plan", "--record"])
            .arg(&record)
            .arg("--report")
            .arg(&report_path)
            .env("RUST_LOG", "info")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("kestrel run --hil"),
    );
    let stderr = kestrel.0.stderr.take().expect("stderr");
    let (lines_tx, lines) = std::sync::mpsc::channel::<String>();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if lines_tx.send(line).is_err() {
                break;
            }
        }
    });
    let mut log = Vec::new();
    let started = Instant::now();
    loop {
        let line = lines.recv_timeout(Duration::from_secs(1)).unwrap_or_default();
        if !line.is_empty() {
            log.push(line.clone());
        }
        if flying_alt(&line).is_some_and(|alt| alt >= SIGNAL_AT_ALT_M) {
            break;
        }
        assert!(kestrel.0.try_wait().expect("status").is_none(), "kestrel ended:\n{}", log.join("\n"));
        assert!(started.elapsed() < Duration::from_secs(120), "never reached 9 m:\n{}", log.join("\n"));
    }
    let sent = Instant::now();
    let kill = Command::new("kill").args([&format!("-{signal}"), &kestrel.0.id().to_string()]).status();
    assert!(kill.expect("kill").success(), "kill -{signal}");
    let status = loop {
        while let Ok(line) = lines.try_recv() {
            log.push(line);
        }
        if let Some(status) = kestrel.0.try_wait().expect("status") {
            break status;
        }
        assert!(
            sent.elapsed() < Duration::from_secs(90),
            "still running 90 s after {signal}:\n{}",
            log.join("\n")
        );
        std::thread::sleep(Duration::from_millis(50));
    };
    log.extend(lines.try_iter());
    let took = sent.elapsed().as_secs_f64();
    let text = log.join("\n");
    println!("SIG{signal}: exited {status:?} {took:.1} s after the signal");
    assert!(status.success(), "SIG{signal}: exit {status:?}\n{text}");

    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report_path).expect("report")).expect("JSON");
    println!("report: flight {} failsafes {}", report["flight"], report["failsafes"]);
    assert_eq!(report["flight"]["landed"], true, "{report:#}");
    assert_eq!(report["flight"]["collisions"], 0, "{report:#}");

    let reader = LogReader::open(&record).expect("the flight log");
    let statuses = reader.read::<VehicleStatus>("vehicle_status").expect("vehicle_status");
    let asked = statuses
        .iter()
        .find(|s| s.message.last_refusal.as_deref() == Some("shutdown requested: landing"))
        .unwrap_or_else(|| panic!("no 'shutdown requested: landing' notice:\n{text}"));
    let t_signal = asked.publish_time;
    assert_eq!(asked.message.mode, FlightMode::Land);
    let disarmed = statuses
        .iter()
        .find(|s| s.publish_time > t_signal && !s.message.armed)
        .unwrap_or_else(|| panic!("never disarmed after the signal"))
        .publish_time;
    let truth = reader.read::<GroundTruth>("ground_truth").expect("ground_truth");
    let descent: Vec<&GroundTruth> = truth
        .iter()
        .filter(|t| t.publish_time >= t_signal && t.publish_time <= disarmed)
        .map(|t| &t.message)
        .collect();
    let alt_at_signal = -descent.first().expect("truth after the signal").position_ned_m[2];
    let fastest = descent.iter().map(|t| t.velocity_ned_m_s[2]).fold(0.0, f64::max);
    let touchdown = descent.iter().find(|t| t.landed).expect("touchdown in the truth");
    assert!(descent.iter().all(|t| !t.crashed), "crashed on the way down");
    let outputs = reader.read::<ActuatorOutputs>("actuator_outputs").expect("actuator_outputs");
    let powered: Vec<&ActuatorOutputs> = outputs
        .iter()
        .filter(|o| o.publish_time >= t_signal && o.publish_time < touchdown.time)
        .map(|o| &o.message)
        .collect();
    let least_mean =
        powered.iter().map(|o| o.motors[..4].iter().sum::<f64>() / 4.0).fold(f64::INFINITY, f64::min);
    println!(
        "SIG{signal}: signal at {:.1} s ({alt_at_signal:.1} m), disarmed at {:.1} s; fastest descent {fastest:.2} m/s, \
         touchdown {:.2} m/s; least mean motor command in the descent {least_mean:.2} over {} outputs",
        t_signal.as_secs_f64(),
        disarmed.as_secs_f64(),
        touchdown.velocity_ned_m_s[2],
        powered.len()
    );
    assert!(alt_at_signal > 8.0, "the signal came at {alt_at_signal:.1} m");
    assert!(powered.iter().all(|o| o.armed), "an unarmed output in the air after SIG{signal}");
    assert!(least_mean > 0.2, "the motors were cut in the air (mean command {least_mean:.2})");
    assert!(fastest < 2.5, "fell at {fastest:.2} m/s");
    assert!(touchdown.velocity_ned_m_s[2] < 1.0, "touched down at {:.2} m/s", touchdown.velocity_ned_m_s[2]);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn sigterm_at_10_m_in_a_mission_lands_under_power_then_exits_0() {
    lands_on("TERM");
}

#[test]
fn sighup_at_10_m_in_a_mission_lands_under_power_then_exits_0() {
    lands_on("HUP");
}

#[test]
fn sigint_at_10_m_in_a_mission_lands_under_power_then_exits_0() {
    lands_on("INT");
}
