//! One vehicle, one process: a second `kestrel run` of the same config and instance, or of any
//! graph opening a device the first holds, fails at start naming the first's pid
//! (`kestrel::locks`); another `--instance` beside the first runs.

mod support;
use support::sim_vehicle;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use sim_vehicle::{Proc, sim_config, stop, temp_dir};

/// `kestrel run` of `config` in the background, its log in `log`.
fn start(config: &Path, extra: &[&str], log: &Path) -> Proc {
    Proc(
        Command::new(env!("CARGO_BIN_EXE_kestrel"))
            .args(["run", "--quiet", "--duration", "600", "--config"])
            .arg(config)
            .args(extra)
            .env_remove("RUST_LOG")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(log).expect("log"))
            .spawn()
            .expect("kestrel run"),
    )
}

/// Waits until `log` shows the graph built (the lock is taken before that).
fn wait_running(log: &Path, kestrel: &mut Proc) {
    let started = Instant::now();
    loop {
        let text = std::fs::read_to_string(log).unwrap_or_default();
        if text.contains("starting") {
            // The instance lock is taken before the graph is built, device locks while it is:
            // give the build a moment.
            std::thread::sleep(Duration::from_millis(500));
            return;
        }
        assert!(kestrel.0.try_wait().expect("status").is_none(), "the first run ended:\n{text}");
        assert!(started.elapsed() < Duration::from_secs(20), "the first run did not start:\n{text}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// A second run to completion (it must fail fast, so a bound of 30 s is generous).
fn second(config: &Path, extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_kestrel"))
        .args(["run", "--quiet", "--duration", "2", "--config"])
        .arg(config)
        .args(extra)
        .env_remove("RUST_LOG")
        .output()
        .expect("second kestrel run")
}

fn sim_graph(dir: &Path) -> PathBuf {
    let gcs = std::net::UdpSocket::bind("127.0.0.1:0").expect("port");
    let port = gcs.local_addr().expect("port").port();
    let path = dir.join("sim.toml");
    std::fs::write(
        &path,
        sim_config(&format!(
            "params.system_id = 1\nparams.endpoints = [ {{ type = \"udp_out\", address = \"127.0.0.1:{port}\" }} ]\n"
        )),
    )
    .expect("config");
    path
}

#[test]
fn a_second_run_of_the_same_config_and_instance_is_refused_naming_the_first_and_another_instance_runs() {
    let dir = temp_dir("instance-lock");
    let config = sim_graph(&dir);
    let log = dir.join("first.log");
    let mut first = start(&config, &["--speedup", "1"], &log);
    wait_running(&log, &mut first);

    let out = second(&config, &["--speedup", "0"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    println!("second run: {:?}\n{stderr}", out.status);
    assert!(!out.status.success(), "a second run of instance 0 started:\n{stderr}");
    assert!(
        stderr.contains(&format!("pid {}", first.0.id())),
        "the error names no pid {}:\n{stderr}",
        first.0.id()
    );
    assert!(stderr.contains("instance 0"), "{stderr}");

    let out = second(&config, &["--speedup", "0", "--instance", "1"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "--instance 1 beside instance 0 failed:\n{stderr}");

    assert!(first.0.try_wait().expect("status").is_none(), "the first run was disturbed");
    assert!(stop(&mut first, "first").success());
    // Released with the process: the same instance runs again.
    let out = second(&config, &["--speedup", "0"]);
    assert!(
        out.status.success(),
        "instance 0 after the first ended:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_second_graph_opening_the_same_serial_device_is_refused_naming_the_device_and_the_first() {
    let dir = temp_dir("device-lock");
    let (tty, other) = (dir.join("radio-tty"), dir.join("gcs-tty"));
    let _socat = Proc(
        Command::new("socat")
            .arg(format!("pty,raw,echo=0,link={}", tty.display()))
            .arg(format!("pty,raw,echo=0,link={}", other.display()))
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("socat (scripts/setup.sh installs it)"),
    );
    let started = Instant::now();
    while !tty.exists() {
        assert!(started.elapsed() < Duration::from_secs(5), "socat made no pseudo-terminal");
        std::thread::sleep(Duration::from_millis(20));
    }
    // Two different link-only graphs (so the instance locks differ) on one radio.
    let graph = |name: &str| {
        let path = dir.join(name);
        std::fs::write(
            &path,
            format!(
                "[run]\nclock = \"realtime\"\n\n[actors.link]\ntype = \"link\"\nparams.endpoints = [ {{ type = \"serial\", device = \"{}\", baud = 57600 }} ]\n",
                tty.display()
            ),
        )
        .expect("config");
        path
    };
    let (a, b) = (graph("a.toml"), graph("b.toml"));
    let log = dir.join("a.log");
    let mut first = start(&a, &[], &log);
    wait_running(&log, &mut first);
    let out = second(&b, &[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    println!("second graph: {:?}\n{stderr}", out.status);
    assert!(!out.status.success(), "a second graph opened the radio:\n{stderr}");
    let device = tty.canonicalize().expect("pty");
    assert!(stderr.contains(&format!("device {}", device.display())), "the error names no device:\n{stderr}");
    assert!(stderr.contains(&format!("pid {}", first.0.id())), "the error names no pid:\n{stderr}");
    assert!(stop(&mut first, "first").success());
    std::fs::remove_dir_all(&dir).ok();
}
