//! What the tests that run `kestrel run` as a child process on the simulator share (tests/gcs.rs,
//! tests/mavlink_sweep.rs): the repository and its Python venv, scratch directories,
//! config/sim.toml with the link's params of the test's choosing, a child process that dies with
//! the test, and stopping the vehicle as an operator does.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// The vehicle's MAVLink parameters as the ground station sees them (the sim config has none).
pub const PARAM_TABLE: &str = r#"[
  { name = "RTL_ALT_M", value = 15.0, min = 5.0, max = 120.0, unit = "m" },
  { name = "WPNAV_SPEED_MS", value = 5.0, min = 0.5, max = 15.0, unit = "m/s" },
  { name = "LAND_SPEED_MS", value = 1.5, min = 0.3, max = 3.0, unit = "m/s" },
  { name = "FENCE_RADIUS_M", value = 300.0, min = 10.0, max = 10000.0, unit = "m" },
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
    text.replace(link, &format!("{link}{link_params}"))
        .replace("\"vehicles/", &format!("\"{}/vehicles/", config_dir.display()))
        .replace("\"worlds/", &format!("\"{}/worlds/", config_dir.display()))
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
pub fn tail(text: &str, lines: usize) -> String {
    let all: Vec<&str> = text.lines().collect();
    all[all.len().saturating_sub(lines)..].join("\n")
}

/// Stops `kestrel` as an operator would (SIGTERM, unless it has exited already) and returns its
/// exit status; it must go within 5 s. `label` names the run in a failure.
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
        assert!(stopping.elapsed() < Duration::from_secs(5), "{label}: kestrel ignored SIGTERM");
        std::thread::sleep(Duration::from_millis(20));
    }
}
