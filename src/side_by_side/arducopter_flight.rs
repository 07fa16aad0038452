//! ArduCopter's side of a row: ArduCopter SITL on Kestrel's physics (`kestrel sitl ardupilot
//! --trace`) flown through the plan by the ground station script
//! (tests/python/ardupilot_square.py: GUIDED take-off to the plan's height, then AUTO), scored on
//! the simulator's truth trace; its estimate is LOCAL_POSITION_NED and ATTITUDE as the ground
//! station received them, at their `time_boot_ms`, which is the physics time.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use serde_json::Value;

use super::score::{Estimate, PlannedPath, Truth, score};
use super::{Flown, SEED, Scenario, Tools};

/// ArduCopter still armed this long (s of its time) on the ground after the mission is disarmed
/// by the script, and the outcome says so: ArduCopter's land detector wants its motors at the
/// lower limit and little acceleration for a second (`LAND_DETECTOR_TRIGGER_SEC`), which in
/// gusts it may never see.
const GROUND_DISARM_S: f64 = 30.0;

/// The ground station script, relative to the repository.
const SCRIPT: &str = "tests/python/ardupilot_square.py";

/// A child process, killed when dropped.
struct Proc(Child);

impl Drop for Proc {
    fn drop(&mut self) {
        if let Ok(None) = self.0.try_wait() {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
}

/// SIGTERM to `child`, then its exit status (killed after 30 s).
fn stop(child: &mut Proc) -> Result<ExitStatus, String> {
    if child.0.try_wait().map_err(|e| e.to_string())?.is_none() {
        // SAFETY: kill(2) on our own child's pid; no memory is touched.
        unsafe { libc::kill(child.0.id() as libc::pid_t, libc::SIGTERM) };
    }
    let stopping = Instant::now();
    loop {
        if let Some(status) = child.0.try_wait().map_err(|e| e.to_string())? {
            return Ok(status);
        }
        if stopping.elapsed() > Duration::from_secs(30) {
            let _ = child.0.kill();
            return Err("kestrel sitl ardupilot ignored SIGTERM for 30 s".into());
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The last `lines` lines of `text`.
fn tail(text: &str, lines: usize) -> String {
    let all: Vec<&str> = text.lines().collect();
    all[all.len().saturating_sub(lines)..].join("\n")
}

/// An ArduCopter SITL instance number whose lock this process now holds and whose ports are free
/// (TCP 5762/5763, UDP 5501 and the JSON physics port 9002, each + 10·N): other runs, tests
/// included, take the others. The lock is held while the returned file lives.
pub fn free_instance() -> Result<(u16, File), String> {
    for n in 1..=60u16 {
        let path = std::env::temp_dir().join(format!("kestrel-arducopter-instance-{n}.lock"));
        let Ok(file) = File::create(&path) else { continue };
        if file.try_lock().is_err() {
            continue;
        }
        let tcp_free =
            [5762, 5763].iter().all(|p| std::net::TcpListener::bind(("0.0.0.0", p + 10 * n)).is_ok());
        let udp_free =
            [5501, 9002].iter().all(|p| std::net::UdpSocket::bind(("0.0.0.0", p + 10 * n)).is_ok());
        if tcp_free && udp_free {
            return Ok((n, file));
        }
    }
    Err("no free ArduCopter SITL instance in 1..=60".into())
}

/// Flies `scenario` with ArduCopter in `dir` (scratch: SITL's directory, summary, trace, logs),
/// giving up after `limit` of wall time.
pub fn fly_arducopter(
    tools: &Tools,
    scenario: &Scenario,
    dir: &Path,
    limit: Duration,
) -> Result<Flown, String> {
    let plan = PlannedPath::read(&scenario.plan)?;
    let label = format!("{} (ArduCopter)", scenario.name);
    let mut client = Command::new(&tools.python);
    client
        .arg(tools.repo.join(SCRIPT))
        .env("PYTHONUNBUFFERED", "1")
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .env("PLAN", &scenario.plan)
        .env("DEADLINE_S", limit.as_secs().to_string())
        .env("TAKEOFF_M", plan.take_off_alt_m.to_string())
        .env("ESTIMATE", "1")
        .env("GROUND_DISARM_S", GROUND_DISARM_S.to_string())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit());
    let mut client = Proc(client.spawn().map_err(|e| format!("start {}: {e}", tools.python.display()))?);
    let (tx, lines) = mpsc::channel::<String>();
    let stdout = client.0.stdout.take().ok_or("the client's stdout")?;
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let first = lines.recv_timeout(Duration::from_secs(15)).unwrap_or_default();
    let port: u16 = first
        .strip_prefix("PORT ")
        .and_then(|p| p.trim().parse().ok())
        .ok_or_else(|| format!("{label}: the client printed {first:?}, not its port"))?;
    let started = Instant::now();
    let (instance, _lock) = free_instance()?;
    let (summary_path, trace_path, log_path) =
        (dir.join("summary.json"), dir.join("trace.json"), dir.join("kestrel-sitl.log"));
    let log = File::create(&log_path).map_err(|e| format!("{}: {e}", log_path.display()))?;
    let sitl = dir.join("sitl.toml");
    let quoted = |p: &Path| format!("{:?}", p.display().to_string());
    std::fs::write(
        &sitl,
        format!(
            "vehicle = {}\nworld = {}\nseed = {SEED}\nframe_rate_hz = 1200.0\ndefaults = [{}, {}]\nspeedup = 100.0\n",
            quoted(&scenario.vehicle),
            quoted(&scenario.world),
            quoted(&scenario.parm),
            quoted(&tools.repo.join("config/ardupilot/side-by-side.parm")),
        ),
    )
    .map_err(|e| format!("{}: {e}", sitl.display()))?;
    let mut command = Command::new(&tools.kestrel);
    command
        .args(["sitl", "ardupilot", "--config"])
        .arg(&sitl)
        .args(["--gcs", &format!("udpclient:127.0.0.1:{port}"), "--instance", &instance.to_string()])
        .arg("--summary")
        .arg(&summary_path)
        .arg("--trace")
        .arg(&trace_path)
        .arg("--dir")
        .arg(dir.join("sitl"))
        .env(kestrel_sim::ardupilot::config::ARDUCOPTER_ENV, &tools.arducopter)
        .stdin(Stdio::null())
        .stdout(log.try_clone().map_err(|e| e.to_string())?)
        .stderr(log);
    if scenario.faults_from_take_off {
        command.arg("--faults-from-take-off");
    }
    let mut physics = Proc(command.spawn().map_err(|e| format!("start {}: {e}", tools.kestrel.display()))?);
    let mut transcript = Vec::new();
    let exit = loop {
        while let Ok(line) = lines.recv_timeout(Duration::from_millis(50)) {
            if tools.echo_transcript {
                println!("  {line}");
            }
            transcript.push(line);
        }
        if let Some(status) = client.0.try_wait().map_err(|e| e.to_string())? {
            transcript.extend(lines.try_iter());
            break Some(status);
        }
        if started.elapsed() > limit || physics.0.try_wait().ok().flatten().is_some() {
            break None;
        }
    };
    let logs = || {
        format!(
            "kestrel:\n{}\nSITL:\n{}",
            tail(&std::fs::read_to_string(&log_path).unwrap_or_default(), 20),
            tail(&std::fs::read_to_string(dir.join("sitl/arducopter.log")).unwrap_or_default(), 30)
        )
    };
    // The physics first, so its summary and trace are written whatever the client said.
    let status = stop(&mut physics)?;
    let summary_text = std::fs::read_to_string(&summary_path).unwrap_or_default();
    if !exit.is_some_and(|s| s.success()) {
        let last = transcript.last().map_or("", String::as_str);
        return Err(format!("{label}: client {exit:?}: {last}\nphysics: {summary_text}\n{}", logs()));
    }
    if !status.success() {
        return Err(format!("{label}: kestrel sitl ardupilot {status}\n{}", logs()));
    }
    let wall_s = started.elapsed().as_secs_f64();
    let json = |text: &str, what: &Path| -> Result<Value, String> {
        serde_json::from_str(text).map_err(|e| format!("{}: {e}", what.display()))
    };
    let summary = json(&summary_text, &summary_path)?;
    let trace = json(&std::fs::read_to_string(&trace_path).map_err(|e| e.to_string())?, &trace_path)?;
    let trace = trace.as_array().ok_or("the trace is no array")?;
    let number = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
    let triple = |v: &Value| [0, 1, 2].map(|i| number(&v[i]));
    let truth: Vec<Truth> = trace
        .iter()
        .map(|s| Truth {
            t_s: number(&s["t_s"]),
            ned_m: triple(&s["position_ned_m"]),
            vel_m_s: triple(&s["velocity_ned_m_s"]),
            attitude: [0, 1, 2, 3].map(|i| number(&s["attitude"][i])),
            landed: s["landed"].as_bool().unwrap_or(false),
        })
        .collect();
    let battery: Vec<(f64, f64, f64)> =
        trace.iter().map(|s| (number(&s["t_s"]), number(&s["voltage_v"]), number(&s["current_a"]))).collect();
    let last_line = transcript.last().ok_or_else(|| format!("{label}: no result line"))?;
    let result: Value =
        serde_json::from_str(last_line).map_err(|e| format!("{label}: last line {e}: {last_line}"))?;
    let results = &result["results"];
    // ArduCopter's boot clock is the physics time: SITL advances it by the differences of the
    // timestamps it is sent, from the first one (`SIM_JSON.cpp`).
    let mut estimates: BTreeMap<u64, Estimate> = BTreeMap::new();
    let blank =
        |t_ms: u64| Estimate { t_s: t_ms as f64 / 1000.0, ned_m: None, vel_m_s: None, euler_rad: None };
    for p in results["local_position_ned"].as_array().ok_or("no local_position_ned")? {
        let (t_ms, f) = (p[0].as_u64().unwrap_or(0), |i: usize| number(&p[i]));
        let e = estimates.entry(t_ms).or_insert_with(|| blank(t_ms));
        e.ned_m = Some([f(1), f(2), f(3)]);
        e.vel_m_s = Some([f(4), f(5), f(6)]);
    }
    for a in results["attitude"].as_array().ok_or("no attitude")? {
        let (t_ms, f) = (a[0].as_u64().unwrap_or(0), |i: usize| number(&a[i]));
        estimates.entry(t_ms).or_insert_with(|| blank(t_ms)).euler_rad = Some([f(1), f(2), f(3)]);
    }
    let estimates: Vec<Estimate> = estimates.into_values().collect();
    let mut score = score(
        &plan,
        &truth,
        &battery,
        &estimates,
        summary["crashed"].as_bool().unwrap_or(true),
        summary["collisions"].as_u64().unwrap_or(0),
    );
    if let Some(after_s) = results["forced_disarm_after_s"].as_f64() {
        score.outcome +=
            &format!(", still armed {after_s:.0} s after touchdown (disarmed by the ground station)");
    }
    Ok(Flown { score, wall_s })
}
