//! `kestrel run` under systemd: the notify protocol as a service manager sees it (a datagram
//! socket of the test's own in `NOTIFY_SOCKET`, the watchdog period in `WATCHDOG_USEC`), and the
//! shipped unit file as `systemd-analyze verify` (Debian's systemd) judges it.

mod support;
use support::sim_vehicle;

use std::os::unix::net::UnixDatagram;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use sim_vehicle::{Proc, root, sim_config, stop, tail, temp_dir};

/// The watchdog period the test asks for (`WatchdogSec=1`).
const WATCHDOG: Duration = Duration::from_secs(1);
/// How long the test watches the watchdog being fed.
const WATCHED: Duration = Duration::from_secs(4);

/// What the service manager received, with when it arrived.
fn receive(socket: &UnixDatagram, until: Instant) -> Vec<(Instant, String)> {
    let mut got = Vec::new();
    let mut buf = [0u8; 4096];
    while Instant::now() < until {
        socket.set_read_timeout(Some(Duration::from_millis(50))).expect("timeout");
        if let Ok(n) = socket.recv(&mut buf) {
            got.push((Instant::now(), String::from_utf8_lossy(&buf[..n]).into_owned()));
        }
    }
    got
}

#[test]
fn a_run_under_a_notify_socket_says_ready_feeds_the_watchdog_in_time_and_says_stopping() {
    let dir = temp_dir("notify");
    let socket_path = dir.join("notify.sock");
    let socket = UnixDatagram::bind(&socket_path).expect("notify socket");
    // A ground station port nobody reads: the link needs somewhere to send.
    let gcs = std::net::UdpSocket::bind("127.0.0.1:0").expect("gcs port");
    let port = gcs.local_addr().expect("port").port();
    let config = dir.join("sim.toml");
    let link = format!(
        "params.system_id = 1\nparams.endpoints = [ {{ type = \"udp_out\", address = \"127.0.0.1:{port}\" }} ]\n"
    );
    std::fs::write(&config, sim_config(&link)).expect("config");
    let log = dir.join("kestrel.log");
    let mut kestrel = Proc(
        Command::new(env!("CARGO_BIN_EXE_kestrel"))
            .args(["run", "--quiet", "--speedup", "1", "--duration", "600", "--config"])
            .arg(&config)
            .env("NOTIFY_SOCKET", &socket_path)
            .env("WATCHDOG_USEC", WATCHDOG.as_micros().to_string())
            .env_remove("WATCHDOG_PID")
            .env_remove("RUST_LOG")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log).expect("log"))
            .spawn()
            .expect("kestrel run"),
    );
    let started = Instant::now();
    // READY first, then pings while the graph runs.
    let mut got = Vec::new();
    while !got.iter().any(|(_, m): &(Instant, String)| m.contains("READY=1")) {
        assert!(started.elapsed() < Duration::from_secs(30), "no READY=1 in 30 s: {got:?}");
        got.extend(receive(&socket, Instant::now() + Duration::from_millis(200)));
    }
    let ready_at = got.iter().find(|(_, m)| m.contains("READY=1")).map(|(t, _)| *t).expect("ready");
    got.extend(receive(&socket, ready_at + WATCHED));
    let pings: Vec<Instant> =
        got.iter().filter(|(t, m)| *t >= ready_at && m.contains("WATCHDOG=1")).map(|(t, _)| *t).collect();
    let gaps: Vec<f64> = std::iter::once(ready_at)
        .chain(pings.iter().copied())
        .collect::<Vec<_>>()
        .windows(2)
        .map(|w| (w[1] - w[0]).as_secs_f64())
        .collect();
    println!(
        "READY after {:.2} s; {} pings in {WATCHED:?}, gaps {gaps:.3?} s",
        (ready_at - started).as_secs_f64(),
        pings.len()
    );
    // Fed at half the period: about 8 in 4 s; never a gap the watchdog would have fired on.
    assert!(pings.len() >= 6, "{} pings in {WATCHED:?} for a {WATCHDOG:?} watchdog: {got:?}", pings.len());
    let worst = gaps.iter().copied().fold(0.0, f64::max);
    assert!(worst < WATCHDOG.as_secs_f64(), "a {worst:.3} s gap: systemd would have killed the service");
    assert!(got.iter().all(|(_, m)| !m.contains("STOPPING=1")), "STOPPING before any signal: {got:?}");

    let status = stop(&mut kestrel, "notify");
    let after = receive(&socket, Instant::now() + Duration::from_millis(300));
    let text = std::fs::read_to_string(&log).unwrap_or_default();
    assert!(status.success(), "kestrel exited {status:?}\n{}", tail(&text, 20));
    assert!(
        after.iter().any(|(_, m)| m.contains("STOPPING=1")),
        "no STOPPING=1 after SIGTERM: {after:?}\n{}",
        tail(&text, 20)
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_shipped_unit_file_passes_systemd_analyze_verify() {
    let unit =
        std::fs::read_to_string(root().join("packaging/kestrel.service")).expect("packaging/kestrel.service");
    for key in ["Type=notify", "WatchdogSec=", "Restart=on-failure", "KillMode=mixed", "TimeoutStopSec="] {
        assert!(unit.contains(key), "the unit sets no {key}");
    }
    // verify checks that ExecStart names an executable: point it at the binary under test.
    let exec = "ExecStart=/usr/local/bin/kestrel ";
    assert!(unit.contains(exec), "the unit starts /usr/local/bin/kestrel");
    let dir = temp_dir("unit");
    let path = dir.join("kestrel.service");
    std::fs::write(&path, unit.replace(exec, &format!("ExecStart={} ", env!("CARGO_BIN_EXE_kestrel"))))
        .expect("unit copy");
    let out = Command::new("systemd-analyze")
        .arg("verify")
        .arg(&path)
        .output()
        .expect("systemd-analyze (Debian's systemd package, installed by scripts/setup.sh --tests)");
    let stderr = String::from_utf8_lossy(&out.stderr);
    println!("systemd-analyze verify: {:?} {stderr}", out.status);
    assert!(out.status.success(), "systemd-analyze verify failed:\n{stderr}");
    assert!(!stderr.contains("kestrel.service:"), "systemd-analyze warns about the unit:\n{stderr}");
    std::fs::remove_dir_all(&dir).ok();
}
