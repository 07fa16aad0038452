//! Kestrel's companion link between ArduCopter SITL and a ground station, against the real
//! thing: ArduCopter 4.7 SITL (`KESTREL_ARDUCOPTER`, its own `--model +` physics, PRX1_TYPE = 2)
//! on the companion's flight-controller endpoint, a pymavlink client
//! (`tests/python/companion_arducopter.py`) on its ground-station endpoint. The companion sends
//! fixed obstacle sectors (3.00 m from 0° to 20°, 7.50 m at 90°, free elsewhere ahead) as the
//! stereo pipeline's would be; what is asserted is what ArduCopter and the client report:
//!
//! * the client sees both heartbeats through the companion (ArduCopter's, and the companion's as
//!   MAV_TYPE_ONBOARD_CONTROLLER / MAV_AUTOPILOT_INVALID from component 196), each frame once;
//! * it arms ArduCopter in GUIDED and takes off through the companion;
//! * ArduCopter's own proximity report (DISTANCE_SENSOR per 45° face) reads the companion's
//!   distances: 300 cm ahead, 750 cm to the right.
//!
//! ArduCopter runs at [`SPEEDUP`] times real time while the companion keeps the wall clock: at
//! 20 Hz of wall time its OBSTACLE_DISTANCE still arrives well inside ArduCopter's 500 ms
//! (its time) proximity timeout. Skipped, with a message, when `KESTREL_ARDUCOPTER` is unset.

#[allow(dead_code, reason = "shared with the other test binaries; this one takes the wall clock")]
mod common;

use std::fs::File;
use std::io::{BufRead, BufReader};
use std::net::{Ipv4Addr, SocketAddr};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::WallClock;
use kestrel_link::companion::{Companion, CompanionOut, DEFAULT_COMPONENT_ID};
use kestrel_link::config::{EndpointConfig, EndpointKind};
use kestrel_link::hub::Hub;
use kestrel_link::transport::{Shared, open_all};
use kestrel_proto::messages::{OBSTACLE_SECTORS, ObstacleSectors, SECTOR_UNKNOWN};
use kestrel_proto::{Clock, Time};
use tokio_util::sync::CancellationToken;

/// ArduCopter's simulated seconds per wall second: its ~40 s wait for GPS in about 13 s.
const SPEEDUP: u32 = 3;
/// The whole session's wall-time limit.
const LIMIT: Duration = Duration::from_secs(60);
/// ArduCopter's parameters on top of its autotest defaults: the companion as its proximity
/// sensor (docs/src/companion-computer.md lists the same).
const PARAMS: &str = "PRX1_TYPE 2\nAVOID_ENABLE 7\nOA_TYPE 1\n";

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Killed when dropped.
struct Proc(Child);

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// An ArduCopter instance number held by a lock file (the scheme tests/support/arducopter.rs
/// uses, so the two never pick the same one) whose ports are free.
fn free_instance() -> (u16, File) {
    for n in 1..=60u16 {
        let path = std::env::temp_dir().join(format!("kestrel-arducopter-instance-{n}.lock"));
        let Ok(file) = File::create(&path) else { continue };
        if file.try_lock().is_err() {
            continue;
        }
        let tcp = [5762, 5763].iter().all(|p| std::net::TcpListener::bind(("0.0.0.0", p + 10 * n)).is_ok());
        let udp = [5501, 9002].iter().all(|p| std::net::UdpSocket::bind(("0.0.0.0", p + 10 * n)).is_ok());
        if tcp && udp {
            return (n, file);
        }
    }
    panic!("no free ArduCopter SITL instance");
}

/// 3.00 m over the five sectors from the nose to 20° right, 7.50 m at 90°, free (max + 1) over
/// the rest of the front half, unknown behind.
fn sectors() -> ObstacleSectors {
    let mut d = vec![SECTOR_UNKNOWN; OBSTACLE_SECTORS];
    for (i, v) in d.iter_mut().enumerate() {
        if i <= 18 || i >= 54 {
            *v = 1201;
        }
    }
    for v in &mut d[0..=4] {
        *v = 300;
    }
    d[18] = 750;
    ObstacleSectors {
        distances_cm: d,
        increment_deg: 5.0,
        angle_offset_deg: 0.0,
        min_distance_cm: 20,
        max_distance_cm: 1200,
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_ground_station_flies_arducopter_through_the_companion_and_arducopter_reads_its_distances() {
    let Some(binary) = std::env::var_os("KESTREL_ARDUCOPTER").map(PathBuf::from) else {
        println!(
            "KESTREL_ARDUCOPTER is not set: SKIPPED (set it to the arducopter binary, e.g. /work/shared/ardupilot/arducopter)"
        );
        return;
    };
    assert!(binary.is_file(), "KESTREL_ARDUCOPTER={} is not a file", binary.display());
    let started = Instant::now();
    // The ground station: a pymavlink client listening on a port of its own.
    let python = root().join(".venv/bin/python");
    let mut client = Proc(
        Command::new(&python)
            .arg(root().join("tests/python/companion_arducopter.py"))
            .env("PYTHONPATH", root().join("tests/python"))
            .env("PYTHONUNBUFFERED", "1")
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .unwrap_or_else(|e| panic!("start {}: {e}", python.display())),
    );
    let mut lines = BufReader::new(client.0.stdout.take().expect("client stdout")).lines();
    let first = lines.next().and_then(Result::ok).unwrap_or_default();
    let gcs_port: u16 = first.strip_prefix("PORT ").and_then(|p| p.trim().parse().ok()).expect("client port");

    // The companion: its flight-controller endpoint a UDP server ArduCopter's serial 0 sends to,
    // its ground-station endpoint a UDP client to the pymavlink client.
    let clock: Arc<dyn Clock> = Arc::new(WallClock(Instant::now()));
    let hub = Arc::new(Mutex::new(Hub::new(Companion::new(DEFAULT_COMPONENT_ID))));
    let published = Arc::new(Mutex::new(Vec::<CompanionOut>::new()));
    let sink = Arc::clone(&published);
    let shutdown = CancellationToken::new();
    let shared = Shared {
        hub: Arc::clone(&hub),
        clock: Arc::clone(&clock),
        shutdown: shutdown.clone(),
        graph: Arc::new(move |out| sink.lock().expect("sink").extend(out)),
        param_writer: None,
        endpoint: 0,
    };
    let loopback = |port| SocketAddr::from((Ipv4Addr::LOCALHOST, port));
    let endpoints = [
        EndpointConfig {
            kind: EndpointKind::UdpIn { bind: loopback(0), max_peers: 2 },
            signing_key_file: None,
        },
        EndpointConfig {
            kind: EndpointKind::UdpOut { address: loopback(gcs_port), bind: None, per_instance: false },
            signing_key_file: None,
        },
    ];
    let open = open_all(&endpoints, Path::new("."), &shared).await.expect("endpoints open");
    let fc_port = open[0].local_addr.expect("bound").port();
    let ticker = shared.clone();
    tokio::spawn(async move {
        let mut tick = tokio::time::interval(Duration::from_millis(20));
        let sectors = sectors();
        for n in 0u64.. {
            tokio::select! {
                _ = ticker.shutdown.cancelled() => break,
                _ = tick.tick() => {}
            }
            let now = ticker.clock.now();
            let out = {
                let mut hub = ticker.hub();
                // A stereo pipeline's 15 Hz, captured 60 ms ago.
                if n % 3 == 0 {
                    hub.station()
                        .on_sectors(Time::from_micros(now.as_micros().saturating_sub(60_000)), &sectors);
                }
                if n.is_multiple_of(50) {
                    hub.send_heartbeat();
                }
                hub.on_tick(now)
            };
            (ticker.graph)(out);
        }
    });

    // ArduCopter SITL, its serial 0 on the companion.
    let (instance, _lock) = free_instance();
    let dir =
        std::env::temp_dir().join(format!("kestrel-companion-arducopter-{}-{instance}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("SITL dir");
    std::fs::write(dir.join("companion.parm"), PARAMS).expect("parm file");
    let defaults = format!(
        "{},{}",
        binary.with_file_name("copter.parm").display(),
        dir.join("companion.parm").display()
    );
    let log = File::create(dir.join("arducopter.log")).expect("SITL log");
    let mut sitl = Proc(
        Command::new(&binary)
            .current_dir(&dir)
            .args(["--model", "+", "--speedup", &SPEEDUP.to_string(), "--defaults", &defaults])
            .args(["--home", "6.79710,79.90170,20,0", "-w", "-I", &instance.to_string(), "--serial0"])
            .arg(format!("udpclient:127.0.0.1:{fc_port}"))
            .stdin(Stdio::null())
            .stdout(log.try_clone().expect("log"))
            .stderr(log)
            .spawn()
            .unwrap_or_else(|e| panic!("start {}: {e}", binary.display())),
    );

    // The client's transcript until it exits.
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in lines.map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let mut transcript = Vec::new();
    let status = loop {
        while let Ok(line) = rx.try_recv() {
            println!("{line}");
            transcript.push(line);
        }
        if let Ok(Some(status)) = client.0.try_wait() {
            break Some(status);
        }
        if started.elapsed() > LIMIT || sitl.0.try_wait().ok().flatten().is_some() {
            break None;
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    };
    while let Ok(line) = rx.recv_timeout(Duration::from_millis(200)) {
        println!("{line}");
        transcript.push(line);
    }
    let wall_s = started.elapsed().as_secs_f64();
    let sitl_log = std::fs::read_to_string(dir.join("arducopter.log")).unwrap_or_default();
    let tail: Vec<&str> = sitl_log.lines().rev().take(20).collect();
    assert!(
        status.is_some_and(|s| s.success()),
        "client {status:?} after {wall_s:.1} s\nSITL:\n{}",
        tail.join("\n")
    );
    let last = transcript.last().expect("a result line");
    let result: serde_json::Value = serde_json::from_str(last).expect("JSON result");
    let r = &result["results"];
    // MAV_TYPE_ONBOARD_CONTROLLER (18), MAV_AUTOPILOT_INVALID (8).
    assert_eq!(r["companion_heartbeat"]["type"], 18, "{r:#}");
    assert_eq!(r["companion_heartbeat"]["autopilot"], 8, "{r:#}");
    assert!(r["max_rel_alt_m"].as_f64().is_some_and(|a| a >= 2.5), "{r:#}");
    assert_eq!(r["proximity_cm"]["0"], 300, "ArduCopter's front face: {r:#}");
    assert_eq!(r["proximity_cm"]["2"], 750, "ArduCopter's right face: {r:#}");
    assert_eq!(r["obstacle_distance"]["frame"], 12, "MAV_FRAME_BODY_FRD: {r:#}");
    assert_eq!(r["duplicates"], 0, "{r:#}");
    // The companion read ArduCopter's state into the graph.
    let navs =
        published.lock().expect("published").iter().filter(|o| matches!(o, CompanionOut::Nav(_))).count();
    let statuses =
        published.lock().expect("published").iter().filter(|o| matches!(o, CompanionOut::Status(_))).count();
    assert!(navs > 50 && statuses > 2, "{navs} NavStates, {statuses} statuses published");
    shutdown.cancel();
    drop(sitl);
    let _ = std::fs::remove_dir_all(&dir);
    println!("companion between ArduCopter and pymavlink: {wall_s:.1} s of wall time, {navs} NavStates");
}
