//! What the tests that run `kestrel run` as a child process on the simulator share (tests/gcs_pymavlink.rs,
//! tests/gcs_mavlink_sweep.rs, tests/gcs_calibration.rs, ...): the repository and its Python venv,
//! scratch directories, config/sim.toml with the link's params and the vehicle of the test's
//! choosing, a child process that dies with the test, a scripted ground-station session, and
//! stopping the vehicle as an operator does.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Output, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// The vehicle's MAVLink parameters as the ground station sees them (the sim config has none).
pub const PARAM_TABLE: &str = r#"[
  { name = "RTL_ALT_M", value = 15.0, min = 5.0, max = 120.0, unit = "m" },
  { name = "WPNAV_SPEED_MS", value = 5.0, min = 0.5, max = 15.0, unit = "m/s" },
  { name = "LAND_SPEED_MS", value = 1.5, min = 0.3, max = 3.0, unit = "m/s" },
  { name = "FENCE_RADIUS", value = 300.0, min = 10.0, max = 10000.0, unit = "m" },
  { name = "FS_GCS_ENABLE", value = 1, min = 0, max = 1, kind = "int32" },
  { name = "FS_GCS_TIMEOUT_S", value = 5.0, min = 1.0, max = 60.0, unit = "s" },
]"#;

/// The repository's root.
pub fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The venv's Python (pymavlink, MAVProxy, mcap).
pub fn python() -> PathBuf {
    let python = root().join(".venv/bin/python");
    assert!(
        python.exists(),
        "no Python venv at {}: run scripts/python-env.sh (it installs pymavlink and MAVProxy from scripts/requirements-*.txt)",
        python.display()
    );
    python
}

/// Starts the client `tests/python/SCRIPT` with the venv's Python, unbuffered, as `setup` further
/// configures it (arguments, environment; stderr is inherited unless set), and returns it with
/// its stdout read line by line into a channel.
pub fn python_client(
    script: &str,
    setup: impl FnOnce(&mut Command) -> &mut Command,
) -> (Proc, mpsc::Receiver<String>) {
    let mut command = Command::new(python());
    command
        .arg(root().join("tests/python").join(script))
        .env("PYTHONUNBUFFERED", "1")
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit());
    let mut client = Proc(setup(&mut command).spawn().expect("start the Python client"));
    let (tx, lines) = mpsc::channel::<String>();
    let stdout = client.0.stdout.take().expect("stdout");
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    (client, lines)
}

/// A fresh temp dir for one test.
pub fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kestrel-gcs-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// config/sim.toml as one file (its bases merged in, `kestrel run --print-config`), the link's
/// params set to `link_params` (TOML lines of dotted keys) and the relative paths made absolute.
pub fn sim_config(link_params: &str) -> String {
    let config_dir = root().join("config");
    let config = kestrel::LoadedConfig::load(&config_dir.join("sim.toml")).expect("config/sim.toml");
    let text = config.merged_toml().expect("the merged graph");
    let link = "[actors.link]\ntype = \"link\"\n";
    assert!(text.contains(link), "config/sim.toml has no [actors.link] with a type:\n{text}");
    assert!(!text.contains("[actors.link.params"), "config/sim.toml's link has params of its own");
    for path in ["\"vehicles/", "\"worlds/"] {
        assert!(text.contains(path), "config/sim.toml names no {path}");
    }
    // Each graph keeps its plans and parameters in a state directory of its own: runs side by
    // side must not restore what another uploaded.
    static RUNS: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    let n = RUNS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let state = std::env::temp_dir().join(format!("kestrel-state-{}-{n}", std::process::id()));
    let shipped_state = "[state]\ndir = \"sim\"\n";
    assert!(text.contains(shipped_state), "config/sim.toml keeps its state in \"sim\":\n{text}");
    text.replace(link, &format!("{link}{link_params}"))
        .replace(shipped_state, &format!("[state]\ndir = \"{}\"\n", state.display()))
        .replace("\"vehicles/", &format!("\"{}/vehicles/", config_dir.display()))
        .replace("\"worlds/", &format!("\"{}/worlds/", config_dir.display()))
}

/// The link's params of a scripted session: system 1, the parameters persisted in `dir`, MAVLink
/// sent to the client's `port`, the vehicle's [`PARAM_TABLE`].
pub fn session_link(port: u16, dir: &Path) -> String {
    format!(
        "params.system_id = 1\nparams.param_file = \"{}\"\nparams.endpoints = [ {{ type = \"udp_out\", address = \"127.0.0.1:{port}\" }} ]\nparams.params = {PARAM_TABLE}\n",
        dir.join("params.txt").display()
    )
}

/// `graph` (from [`sim_config`]) with `vehicle` (a path in the repository) as the graph's vehicle
/// instead of config/vehicles/quad_x.toml: the simulator flies it, the controller controls it.
pub fn on_vehicle(graph: &str, vehicle: &str) -> String {
    let default = format!("vehicle = \"{}\"", root().join("config/vehicles/quad_x.toml").display());
    assert!(graph.contains(&default), "config/sim.toml names vehicles/quad_x.toml");
    graph.replace(&default, &format!("vehicle = \"{}\"", root().join(vehicle).display()))
}

/// How long one scripted session may take on the wall clock (the vehicle at 5× speed-up).
const CLIENT_LIMIT: Duration = Duration::from_secs(150);

/// Runs the Python client `script` (with the environment `env`) against `kestrel run` at 5×
/// speed-up on the graph `config` writes for the UDP port the client reports on its first line
/// (`PORT n`), waits for the client to exit 0, stops the vehicle, and returns the JSON of the
/// client's last line. `scenario` names the files in `dir` and the run in a failure.
pub fn scripted_session(
    dir: &Path,
    scenario: &str,
    script: &str,
    env: &[(&str, String)],
    config: impl FnOnce(u16) -> String,
) -> serde_json::Value {
    let (mut client, lines) = python_client(script, |c| c.envs(env.iter().map(|(k, v)| (k, v))));
    let first = lines.recv_timeout(Duration::from_secs(15)).unwrap_or_default();
    let port: u16 = first.strip_prefix("PORT ").and_then(|p| p.trim().parse().ok()).expect("client port");
    let config_path = dir.join(format!("{scenario}.toml"));
    std::fs::write(&config_path, config(port)).expect("config");
    let log_path = dir.join(format!("{scenario}.log"));
    let mut kestrel = kestrel_at_5x(dir, &config_path, &log_path, "600");
    println!("── {scenario} ──");
    let started = Instant::now();
    let (exit, transcript) = transcript_until_exit(&mut client, &lines, || started.elapsed() > CLIENT_LIMIT);
    let log = || tail(&std::fs::read_to_string(&log_path).unwrap_or_default(), 30);
    assert!(exit.is_some_and(|s| s.success()), "{scenario}: client {exit:?}\n{}", log());
    assert!(stop(&mut kestrel, scenario).success(), "{scenario}: kestrel failed\n{}", log());
    println!("{scenario} took {:.1} s", started.elapsed().as_secs_f64());
    let last = transcript.last().expect("a result line");
    serde_json::from_str(last)
        .unwrap_or_else(|e| panic!("{scenario}: the last line is no JSON result ({e}): {last}"))
}

/// `kestrel run` of `config_path` at 5× speed-up from `dir` for at most `duration_s` of vehicle
/// time, its log in `log_path`.
pub fn kestrel_at_5x(dir: &Path, config_path: &Path, log_path: &Path, duration_s: &str) -> Proc {
    Proc(
        Command::new(env!("CARGO_BIN_EXE_kestrel"))
            .current_dir(dir)
            .env_remove("RUST_LOG")
            .args(["run", "--quiet", "--speedup", "5", "--duration", duration_s, "--config"])
            .arg(config_path)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(log_path).expect("log"))
            .spawn()
            .expect("start kestrel run"),
    )
}

/// Prints and keeps each line the client writes until it exits (its status), or until
/// `give_up()` (`None`).
pub fn transcript_until_exit(
    client: &mut Proc,
    lines: &std::sync::mpsc::Receiver<String>,
    mut give_up: impl FnMut() -> bool,
) -> (Option<ExitStatus>, Vec<String>) {
    let mut transcript = Vec::new();
    loop {
        while let Ok(line) = lines.recv_timeout(Duration::from_millis(50)) {
            println!("  {line}");
            transcript.push(line);
        }
        if let Some(status) = client.0.try_wait().expect("client status") {
            transcript.extend(lines.try_iter());
            return (Some(status), transcript);
        }
        if give_up() {
            return (None, transcript);
        }
    }
}

/// Flies config/missions/square.plan in-process in lockstep on `vehicle` over the empty world
/// (seed 1), with the link's parameter file `param_file` (if any) and no endpoints, recording to
/// `record` (if any); returns the flight report, whose mission must have completed.
pub fn square_in_process(
    dir: &Path,
    label: &str,
    vehicle: &str,
    param_file: Option<&Path>,
    record: Option<PathBuf>,
) -> serde_json::Value {
    plan_in_process(dir, label, "missions/square.plan", vehicle, param_file, record)
}

/// As [`square_in_process`], flying `plan` (a path under config/).
pub fn plan_in_process(
    dir: &Path,
    label: &str,
    plan: &str,
    vehicle: &str,
    param_file: Option<&Path>,
    record: Option<PathBuf>,
) -> serde_json::Value {
    let config_dir = root().join("config");
    let mut config = kestrel::LoadedConfig::load(&config_dir.join("sim.toml")).expect("sim.toml");
    let table = |pairs: Vec<(&str, toml::Value)>| -> toml::Table {
        pairs.into_iter().map(|(k, v)| (k.to_owned(), v)).collect()
    };
    // The graph's vehicle: the simulator flies it and the controller controls its airframe.
    config.graph.vehicle = Some(toml::Spanned::new(0..0, root().join(vehicle).display().to_string()));
    for actor in config.graph.actors.values_mut() {
        let params = match actor.kind.get_ref().as_str() {
            "commander" => table(vec![
                ("mission", config_dir.join(plan).display().to_string().into()),
                ("auto", true.into()),
                ("exit_on_land", true.into()),
            ]),
            "sim" => table(vec![
                ("world", config_dir.join("worlds/empty.toml").display().to_string().into()),
                ("seed", 1.into()),
            ]),
            "link" => {
                let mut t = table(vec![("endpoints", toml::Value::Array(Vec::new()))]);
                if let Some(file) = param_file {
                    t.insert("param_file".into(), file.display().to_string().into());
                }
                t
            }
            _ => continue,
        };
        actor.params = Some(toml::Spanned::new(0..0, params));
    }
    let report_path = dir.join(format!("{label}-report.json"));
    let options = kestrel::RunOptions {
        duration: Some(Duration::from_secs(200)),
        speedup: Some(0.0),
        record,
        report: Some(report_path.clone()),
        ..Default::default()
    };
    kestrel::run(&config, &kestrel::Registry::standard(), options).expect("the flight ran");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report_path).expect("report")).expect("JSON");
    assert_eq!(report["mission"]["completed"], true, "{label}: {report:#}");
    report
}

/// A child process killed (and reaped) when dropped, so a failing test leaves nothing behind.
pub struct Proc(pub Child);

impl Drop for Proc {
    fn drop(&mut self) {
        if let Ok(None) = self.0.try_wait() {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
}

/// The last `lines` lines of `text`.
/// Runs the shell `script` in a network namespace of its own (so its vehicles' fixed ports are
/// the test's alone) from `dir`, with `KESTREL`, `PYTHON`, `DIR` and the test's `env` set: a
/// fleet of `kestrel run`s and the client that watches them.
pub fn fleet_in_own_network(script: &str, dir: &Path, env: &[(&str, PathBuf)]) -> Output {
    Command::new("unshare")
        .args(["--net", "--map-root-user", "sh", "-c", script])
        .env("KESTREL", env!("CARGO_BIN_EXE_kestrel"))
        .env("PYTHON", python())
        .env("DIR", dir)
        .envs(env.iter().map(|(k, v)| (*k, v)))
        .env("PYTHONUNBUFFERED", "1")
        .env_remove("RUST_LOG")
        .current_dir(dir)
        .output()
        .expect("unshare (util-linux) runs the fleet in a network namespace of its own")
}

pub fn tail(text: &str, lines: usize) -> String {
    let all: Vec<&str> = text.lines().collect();
    all[all.len().saturating_sub(lines)..].join("\n")
}

/// Stops `kestrel` as an operator would (SIGTERM, unless it has exited already) and returns its
/// exit status. A vehicle in the air lands before the process ends (`kestrel::shutdown`): from
/// 10 m that is some 10 simulated seconds, which a loaded 2-core host at 5× takes several wall
/// seconds to fly, so the process has 30 s. `label` names the run in a failure.
pub fn stop(kestrel: &mut Proc, label: &str) -> ExitStatus {
    if kestrel.0.try_wait().expect("kestrel status").is_none() {
        let kill = std::process::Command::new("kill")
            .args(["-TERM", &kestrel.0.id().to_string()])
            .status()
            .expect("kill");
        assert!(kill.success(), "{label}: SIGTERM to kestrel");
    }
    let stopping = Instant::now();
    loop {
        if let Some(status) = kestrel.0.try_wait().expect("kestrel status") {
            return status;
        }
        assert!(stopping.elapsed() < Duration::from_secs(30), "{label}: kestrel ignored SIGTERM");
        std::thread::sleep(Duration::from_millis(20));
    }
}
