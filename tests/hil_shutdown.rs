//! Stopping the process never drops a flying vehicle: the Navio2 graph (`config/navio2.toml`,
//! realtime, the real drivers) flies config/missions/square.plan with `--hil` against the
//! emulated board, and at 10 m a SIGTERM, SIGHUP or SIGINT arrives, as from `systemctl stop`, a
//! dropped SSH session or Ctrl-C. Each must land the vehicle under power and only then end the
//! process, with exit status 0 (`kestrel::shutdown`).
//!
//! What is checked, from the run's own recording and report:
//! * the commander switched to LAND with the notice "shutdown requested: landing";
//! * from the signal to ground contact the controller kept the motors armed and spinning
//!   (every `actuator_outputs` armed, no motor held at 0, the mean command near hover's), and the
//!   simulated vehicle came down at a landing's speed (never faster than 2.5 m/s, touching
//!   down slower than 1 m/s), intact and without collision;
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
    // Ground contact: the first truth within 0.3 m of the ground (the landed flag settles later).
    let contact = descent.iter().find(|t| -t.position_ned_m[2] < 0.3).expect("ground contact in the truth");
    assert!(descent.iter().all(|t| !t.crashed), "crashed on the way down");
    let touchdown_m_s = report["flight"]["touchdown"]["speed_down_m_s"].as_f64().expect("touchdown speed");
    let outputs = reader.read::<ActuatorOutputs>("actuator_outputs").expect("actuator_outputs");
    let powered: Vec<&ActuatorOutputs> = outputs
        .iter()
        .filter(|o| o.publish_time >= t_signal && o.publish_time < contact.time)
        .map(|o| &o.message)
        .collect();
    let means: Vec<f64> = powered.iter().map(|o| o.motors[..4].iter().sum::<f64>() / 4.0).collect();
    let average = means.iter().sum::<f64>() / means.len().max(1) as f64;
    // The longest time any motor was commanded to 0 while armed (s): the mixer's low
    // saturation while braking a climb, or a cut.
    let mut longest_at_zero = 0.0_f64;
    let mut since: Option<f64> = None;
    for o in &powered {
        let t = o.time.as_secs_f64();
        if o.motors[..4].iter().any(|m| *m <= 0.0) {
            let start = *since.get_or_insert(t);
            longest_at_zero = longest_at_zero.max(t - start);
        } else {
            since = None;
        }
    }
    println!(
        "SIG{signal}: signal at {:.1} s ({alt_at_signal:.1} m), disarmed at {:.1} s; fastest descent {fastest:.2} m/s, \
         touchdown {touchdown_m_s:.2} m/s; motor command above the ground: mean {average:.2}, longest at 0 {longest_at_zero:.3} s over {} outputs",
        t_signal.as_secs_f64(),
        disarmed.as_secs_f64(),
        powered.len()
    );
    assert!(alt_at_signal > 8.0, "the signal came at {alt_at_signal:.1} m");
    assert!(powered.iter().all(|o| o.armed), "an unarmed output in the air after SIG{signal}");
    // Braking the climb may saturate a motor at 0 for a moment, as any commanded LAND does; a
    // cut would hold it there.
    assert!(longest_at_zero < 0.25, "a motor was held at 0 for {longest_at_zero:.2} s in the air");
    assert!(average > 0.25, "the descent was not flown under power (mean command {average:.2})");
    assert!(fastest < 2.5, "fell at {fastest:.2} m/s");
    assert!(touchdown_m_s < 1.0, "touched down at {touchdown_m_s:.2} m/s");
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
