//! Against the real vehicle: independent ground stations (pymavlink and
//! MAVProxy, from the venv made by `scripts/python-env.sh`) talk to `kestrel run` on the
//! simulator over UDP loopback, and pymavlink flies it again over a serial link (two
//! pseudo-terminals joined by `socat`, 57600 baud).
//!
//! Each test writes config/sim.toml's text to a temp dir with only the link's params changed:
//! one `udp_out` endpoint to the port the client listens on (127.0.0.1, ephemeral, so parallel
//! tests never collide; no UDP server on 14540), a parameter table, and per test a parameter
//! file or a signing key. The sim's vehicle and world paths are made absolute so they resolve
//! from the temp dir. The vehicle runs `--speedup 5` with `--duration` as a hard bound; the
//! client's transcript (wall time, vehicle time, event) is printed for `--nocapture`. A test
//! passes when the client exits 0 and `kestrel` exits 0 on SIGTERM; on failure both are killed.

mod support;
use support::{merged_config, sim_vehicle};

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use merged_config::without_sections;
use sim_vehicle::{PARAM_TABLE, Proc, python_client, root, sim_config, stop, tail, temp_dir};

/// Simulated seconds per wall second: a 60 s flight takes 12 s, and the 5 s (vehicle time)
/// link-loss timeout is a full second of wall time, ten of the client's heartbeats.
const SPEEDUP: &str = "5";
/// Hard bound on one run, in vehicle seconds (`--duration`): 40 s of wall time.
const DURATION_S: &str = "200";
/// Wall-clock bound on one client.
const CLIENT_LIMIT: Duration = Duration::from_secs(55);

/// The link's params for a ground station at 127.0.0.1:`port`; `endpoint_extra` goes into the
/// endpoint's table, `extra` after it.
fn link_params(port: u16, endpoint_extra: &str, extra: &str) -> String {
    format!(
        "params.system_id = 1\n\
         params.endpoints = [ {{ type = \"udp_out\", address = \"127.0.0.1:{port}\"{endpoint_extra} }} ]\n\
         params.params = {PARAM_TABLE}\n{extra}"
    )
}

/// What one client run produced.
struct Flight {
    transcript: Vec<String>,
    kestrel_log: String,
    /// `kestrel run --report`'s JSON: what the vehicle did, as the program reports it.
    report: serde_json::Value,
}

impl Flight {
    /// Whether the vehicle ended the run on the ground, in one piece (the report's
    /// `flight.landed`; the clients saw it land and disarm over MAVLink).
    fn landed(&self) -> bool {
        self.report["flight"]["landed"] == serde_json::Value::Bool(true)
    }

    /// The causes of the failsafes that fired, as the report names them (`data_link_lost`).
    fn failsafe_causes(&self) -> Vec<&str> {
        let entries = self.report["failsafes"].as_array().map(Vec::as_slice).unwrap_or_default();
        entries.iter().filter_map(|f| f["cause"].as_str()).collect()
    }
}

/// Runs `script ARGS` against `kestrel run` with the config `link(port)` makes, in `dir`.
fn fly(dir: &Path, label: &str, script: &str, args: &[&str], link: impl Fn(u16) -> String) -> Flight {
    fly_with_env(dir, label, script, args, &[], |port| sim_config(&link(port)))
}

/// [`fly`] with extra environment variables for the client (`GCS_SERIAL`: talk over a serial
/// device instead of UDP, announcing port 0) and the whole config text `config(port)` makes.
fn fly_with_env(
    dir: &Path,
    label: &str,
    script: &str,
    args: &[&str],
    env: &[(&str, &str)],
    config: impl Fn(u16) -> String,
) -> Flight {
    let (mut client, lines) = python_client(script, |c| {
        c.args(args).envs(env.iter().copied()).env_remove("MAVLINK20").stderr(Stdio::piped())
    });
    let mut stderr_pipe = client.0.stderr.take().expect("stderr");
    let stderr = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stderr_pipe.read_to_string(&mut s);
        s
    });
    let first = lines.recv_timeout(Duration::from_secs(15)).unwrap_or_default();
    let Some(port) = first.strip_prefix("PORT ").and_then(|p| p.trim().parse::<u16>().ok()) else {
        drop(client);
        panic!(
            "{label}: the client did not announce its port: {first:?}\n{}",
            stderr.join().unwrap_or_default()
        );
    };

    let config_path = dir.join(format!("{label}.toml"));
    std::fs::write(&config_path, config(port)).expect("write the config");
    let log_path = dir.join(format!("{label}.log"));
    let report_path = dir.join(format!("{label}-report.json"));
    let log = std::fs::File::create(&log_path).expect("log file");
    let mut kestrel = Proc(
        Command::new(env!("CARGO_BIN_EXE_kestrel"))
            .current_dir(dir)
            .env_remove("RUST_LOG")
            .args(["run", "--quiet", "--speedup", SPEEDUP, "--duration", DURATION_S, "--config"])
            .arg(&config_path)
            .arg("--report")
            .arg(&report_path)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(log)
            .spawn()
            .expect("start kestrel run"),
    );
    println!("── {label}: {script} {} against kestrel run (client port {port}) ──", args.join(" "));

    let started = Instant::now();
    let mut transcript = Vec::new();
    let mut kestrel_exit = None;
    let client_exit = loop {
        while let Ok(line) = lines.recv_timeout(Duration::from_millis(50)) {
            println!("  {line}");
            transcript.push(line);
        }
        if let Some(status) = client.0.try_wait().expect("client status") {
            while let Ok(line) = lines.recv_timeout(Duration::from_millis(200)) {
                println!("  {line}");
                transcript.push(line);
            }
            break Some(status);
        }
        if kestrel_exit.is_none() {
            kestrel_exit = kestrel.0.try_wait().expect("kestrel status");
        }
        if started.elapsed() > CLIENT_LIMIT {
            break None;
        }
    };
    let read_log = || std::fs::read_to_string(&log_path).unwrap_or_default();
    let ok = client_exit.is_some_and(|s| s.success());
    if !ok {
        drop(client);
        drop(kestrel);
        panic!(
            "{label}: the client {} (kestrel: {kestrel_exit:?})\nclient stderr:\n{}\nkestrel log (tail):\n{}",
            client_exit.map_or("ran past its time limit".to_owned(), |s| format!("failed with {s}")),
            stderr.join().unwrap_or_default(),
            tail(&read_log(), 40)
        );
    }
    assert!(
        transcript.last().is_some_and(|l| l.starts_with("{\"ok\": true")),
        "{label}: no result line: {transcript:?}"
    );

    // The client is done: stop the vehicle as an operator would.
    let status = stop(&mut kestrel, label);
    let kestrel_log = read_log();
    assert!(status.success(), "{label}: kestrel exited with {status}\n{}", tail(&kestrel_log, 40));
    println!("── {label}: client exit 0, kestrel exit 0 after {:.1} s ──", started.elapsed().as_secs_f64());
    let report = std::fs::read_to_string(&report_path).expect("kestrel wrote its report");
    let report = serde_json::from_str(&report).expect("the report is JSON");
    Flight { transcript, kestrel_log, report }
}

#[test]
fn a_ground_station_that_arms_first_then_sends_mission_start_flies_the_mission() {
    let dir = temp_dir("mission-start");
    let plan = root().join("config/missions/square.plan");
    let plan = plan.to_str().expect("utf-8 path");
    let flight = fly(&dir, "mission-start", "gcs_flight.py", &[plan, "--mission-start"], |port| {
        link_params(port, "", "")
    });
    let result = flight.transcript.last().expect("result");
    assert!(result.contains("\"reached\": [1, 2, 3, 4, 5"), "{result}");
    assert!(flight.landed(), "{:#}", flight.report);
}

#[test]
fn a_ground_station_flies_the_square_mission_through_telemetry_alone() {
    let dir = temp_dir("flight");
    let plan = root().join("config/missions/square.plan");
    let flight = fly(&dir, "flight", "gcs_flight.py", &[plan.to_str().expect("utf-8 path")], |port| {
        link_params(port, "", "")
    });
    let result = flight.transcript.last().expect("result");
    for needed in ["\"downloaded_identical\": true", "\"RTL\"", "\"reached\": [1, 2, 3, 4, 5"] {
        assert!(result.contains(needed), "{needed} not in {result}");
    }
    assert!(flight.landed(), "{:#}", flight.report);
    // The client set RTL_ALT_M = 25 before the flight (the commander's default is 15 m): the
    // return climbed to the new altitude, so the change was applied live.
    let result: serde_json::Value = serde_json::from_str(result).expect("JSON result line");
    let max_alt = result["results"]["flight"]["max_alt_m"].as_f64().expect("max_alt_m");
    assert!((24.0..27.0).contains(&max_alt), "RTL climbed to {max_alt} m, not the 25 m set over MAVLink");
    std::fs::remove_dir_all(&dir).ok();
}

/// ArduPilot SITL's way of checking a wind estimate: SIM_WIND_SPD/DIR set over MAVLink, WIND read
/// back in a hover (the estimator learns it from drag, `config/sim.toml`'s model).
#[test]
fn a_ground_station_reads_back_the_wind_it_set_in_the_simulator() {
    let dir = temp_dir("wind");
    let flight = fly(&dir, "wind", "gcs_wind.py", &[], |port| link_params(port, "", ""));
    let result = flight.transcript.last().expect("result");
    println!("figure: WIND in a 3 m/s wind from 225 deg: {result}");
    assert!(result.contains("\"wind\""), "{result}");
    assert!(flight.landed(), "{:#}", flight.report);
    std::fs::remove_dir_all(&dir).ok();
}

/// The upward and downward rangefinders as a ground station reads them (DISTANCE_SENSOR,
/// orientations 24 and 25) on a take-off under a slab 6 m up, and the STATUSTEXT that says the
/// climb is held 2 m below it.
#[test]
fn a_ground_station_sees_a_takeoff_held_under_a_slab_and_both_rangefinders() {
    let dir = temp_dir("rangefinder");
    let world = dir.join("slab.toml");
    let empty = std::fs::read_to_string(root().join("config/worlds/empty.toml")).expect("empty world");
    let slab = "[[obstacles]]\nkind = \"box\"\ncenter_ned_m = [0.0, 0.0, -7.0]\nsize_m = [8.0, 8.0, 2.0]\n";
    std::fs::write(&world, format!("{empty}\n{slab}")).expect("world");
    let empty_path = format!("\"{}\"", root().join("config/worlds/empty.toml").display());
    let flight = fly_with_env(&dir, "rangefinder", "gcs_rangefinder.py", &[], &[], |port| {
        let graph = sim_config(&link_params(port, "", ""));
        assert!(graph.contains(&empty_path), "config/sim.toml flies worlds/empty.toml");
        graph.replace(&empty_path, &format!("\"{}\"", world.display()))
    });
    let result = flight.transcript.last().expect("result");
    println!("figure: take-off to 10 m under a slab 6 m up: {result}");
    assert!(result.contains("\"rangefinder\""), "{result}");
    assert_eq!(flight.report["flight"]["collisions"], 0, "{:#}", flight.report);
    assert!(flight.landed(), "{:#}", flight.report);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn losing_the_ground_station_in_flight_returns_and_lands() {
    let dir = temp_dir("link-loss");
    let flight = fly(&dir, "link-loss", "gcs_link_loss.py", &[], |port| link_params(port, "", ""));
    assert!(
        flight.transcript.iter().any(|l| l.contains("Failsafe: GCS link lost")),
        "{:?}",
        flight.transcript
    );
    assert!(flight.failsafe_causes().contains(&"data_link_lost"), "{:#}", flight.report);
    assert!(flight.landed(), "{:#}", flight.report);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn with_fs_gcs_enable_set_to_land_losing_the_ground_station_lands_where_it_is() {
    let dir = temp_dir("link-loss-land");
    let flight = fly(&dir, "link-loss-land", "gcs_link_loss.py", &["land"], |port| link_params(port, "", ""));
    let causes = flight.failsafe_causes();
    assert!(causes.contains(&"data_link_lost"), "{:#}", flight.report);
    let actions: Vec<&str> = flight.report["failsafes"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|f| f["action"].as_str())
        .collect();
    assert_eq!(actions, ["land"], "{:#}", flight.report);
    assert!(flight.landed(), "{:#}", flight.report);
    let from_home = flight.report["flight"]["landing_distance_from_home_m"].as_f64().unwrap_or(f64::NAN);
    println!("figure: FS_GCS_ENABLE=5 link loss: failsafes {actions:?}, landed {from_home:.2} m from home");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_parameter_set_over_mavlink_survives_a_restart() {
    let dir = temp_dir("params");
    let with_file = |port| link_params(port, "", "params.param_file = \"params.txt\"\n");
    fly(&dir, "params-set", "gcs_params.py", &["set", "RTL_ALT_M", "42.5"], with_file);
    let saved =
        std::fs::read_to_string(dir.join("params.txt")).expect("params.txt written next to the config");
    assert!(saved.lines().any(|l| l == "RTL_ALT_M=42.5"), "{saved}");
    fly(&dir, "params-restart", "gcs_params.py", &["expect", "RTL_ALT_M", "42.5"], with_file);
    std::fs::remove_dir_all(&dir).ok();
}

/// A directory nothing can be written to, for as long as it lives: a read-only tmpfs mounted on
/// it where the test may mount (as root: permission bits do not stop root), else its permission
/// bits cleared; `None` when neither keeps a write out.
struct ReadOnlyDir {
    path: PathBuf,
    mounted: bool,
}

impl ReadOnlyDir {
    fn new(path: PathBuf) -> Option<ReadOnlyDir> {
        std::fs::create_dir_all(&path).expect("directory");
        let mounted = Command::new("mount")
            .args(["-t", "tmpfs", "-o", "ro,size=64k", "tmpfs"])
            .arg(&path)
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if !mounted {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o555)).expect("chmod 555");
        }
        let dir = ReadOnlyDir { path, mounted };
        let probe = dir.path.join("probe");
        if std::fs::write(&probe, "x").is_ok() {
            let _ = std::fs::remove_file(&probe);
            return None;
        }
        Some(dir)
    }
}

impl Drop for ReadOnlyDir {
    fn drop(&mut self) {
        if self.mounted {
            let _ = Command::new("umount").arg(&self.path).status();
        } else {
            use std::os::unix::fs::PermissionsExt;
            let _ = std::fs::set_permissions(&self.path, std::fs::Permissions::from_mode(0o755));
        }
    }
}

/// ArduPilot answers a set only once its storage took it; ours answers once the parameter file
/// holds it. A file that cannot be written answers with the value the vehicle still uses and a
/// STATUSTEXT saying why (docs/src/decisions/0048-a-parameter-is-set-once-it-is-stored.md).
#[test]
fn a_parameter_set_that_cannot_be_stored_is_answered_with_the_old_value_and_why() {
    let dir = temp_dir("params-read-only");
    let Some(read_only) = ReadOnlyDir::new(dir.join("read-only")) else {
        println!("skipped: this host lets every write through (no mount, and root ignores modes)");
        return;
    };
    let how = if read_only.mounted { "a read-only tmpfs" } else { "mode 555" };
    let in_it = |port| link_params(port, "", "params.param_file = \"read-only/params.txt\"\n");
    let flight = fly(&dir, "params-read-only", "gcs_params.py", &["unsaved", "RTL_ALT_M", "42.5"], in_it);
    let result = flight.transcript.last().expect("result");
    println!("figure: PARAM_SET with the parameter file on {how}: {result}");
    drop(read_only);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_parameter_whose_owner_never_hears_the_set_keeps_its_old_value() {
    let dir = temp_dir("params-unrouted");
    // No actor subscribes to the link's ParamSets (every `inputs.param_set` left out, as in a
    // hand-made graph): no set can be applied, and none may be echoed as if it were.
    let unrouted = |port| {
        let text = sim_config(&link_params(port, "", ""));
        let text = without_sections(&text, |header, _| header.ends_with(".inputs.param_set]"));
        assert!(!text.contains("param_set"), "{text}");
        text
    };
    let args = ["unapplied", "RTL_ALT_M", "42.5"];
    fly_with_env(&dir, "params-unrouted", "gcs_params.py", &args, &[], unrouted);
    std::fs::remove_dir_all(&dir).ok();
}

/// Pulse ranges and sensor calibration are disarmed-only (`param_def::WhileArmed::Locked`): set in
/// a hover at 10 m they are refused with a STATUSTEXT and the value in force, and the hover goes
/// on; on the ground the same parameters take new values (tests/python/gcs_armed_params.py).
#[test]
fn output_and_calibration_parameters_are_refused_in_flight_and_taken_on_the_ground() {
    let dir = temp_dir("armed-params");
    let flight = fly(&dir, "armed-params", "gcs_armed_params.py", &[], |port| link_params(port, "", ""));
    let result = flight.transcript.last().expect("result");
    println!("figure: disarmed-only parameters set in flight and on the ground: {result}");
    assert!(flight.failsafe_causes().is_empty(), "{:#}", flight.report);
    assert_eq!(flight.report["flight"]["collisions"], 0, "{:#}", flight.report);
    assert!(flight.landed(), "{:#}", flight.report);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn with_signing_on_only_a_client_holding_the_key_can_arm() {
    let dir = temp_dir("signing");
    let key: String = (0u8..32).map(|i| format!("{:02x}", i.wrapping_mul(37).wrapping_add(11))).collect();
    std::fs::write(dir.join("gcs.key"), format!("{key}\n")).expect("key file");
    // A key file group or others may read is refused (as ssh refuses such a private key).
    std::fs::set_permissions(dir.join("gcs.key"), std::os::unix::fs::PermissionsExt::from_mode(0o600))
        .expect("chmod 600 the key file");
    let flight = fly(&dir, "signing", "gcs_signing.py", &[&key], |port| {
        link_params(port, ", signing_key_file = \"gcs.key\"", "")
    });
    // The client checked over MAVLink that unsigned and wrongly signed commands were ignored;
    // the link's own count of them is a figure, from its counters line.
    let refused = flight
        .kestrel_log
        .lines()
        .find(|l| l.contains("MAVLink link counters"))
        .and_then(|l| l.split("unsigned_refused: ").nth(1))
        .and_then(|s| s.split(|c: char| !c.is_ascii_digit()).next())
        .and_then(|n| n.parse::<u64>().ok());
    println!("kestrel counted {} refused frames", refused.unwrap_or(0));
    std::fs::remove_dir_all(&dir).ok();
}

/// One replay table and a stored timestamp (tests/python/gcs_signing_replay.py): a signed
/// frame captured on the `udp_out` endpoint and sent to the `udp_in` one is refused, and so is
/// it after `kestrel run` restarts; an unsigned RADIO_STATUS on the signed link thins telemetry.
#[test]
fn signed_frames_replayed_on_another_endpoint_or_after_a_restart_are_refused() {
    let dir = temp_dir("signing-replay");
    let key: String = (0u8..32).map(|i| format!("{:02x}", i.wrapping_mul(53).wrapping_add(7))).collect();
    std::fs::write(dir.join("gcs.key"), format!("{key}\n")).expect("key file");
    std::fs::set_permissions(dir.join("gcs.key"), std::os::unix::fs::PermissionsExt::from_mode(0o600))
        .expect("chmod 600 the key file");
    let replay_port =
        std::net::UdpSocket::bind("127.0.0.1:0").and_then(|s| s.local_addr()).expect("a free port").port();
    let capture = dir.join("captured.hex");
    let capture = capture.to_str().expect("utf-8 path");
    let port_arg = replay_port.to_string();
    let link = |port| {
        // The second endpoint closes the template's braces: a signed `udp_in` on `replay_port`.
        let second = format!(
            ", signing_key_file = \"gcs.key\" }}, {{ type = \"udp_in\", bind = \"127.0.0.1:{replay_port}\", \
             max_peers = 2, signing_key_file = \"gcs.key\""
        );
        link_params(port, &second, "")
    };
    let started = Instant::now();
    let before =
        fly(&dir, "signing-before", "gcs_signing_replay.py", &[&key, "before", capture, &port_arg], link);
    let after =
        fly(&dir, "signing-after", "gcs_signing_replay.py", &[&key, "after", capture, &port_arg], link);
    for (run, flight) in [("before", &before), ("after", &after)] {
        let counters: Vec<&str> =
            flight.kestrel_log.lines().filter(|l| l.contains("MAVLink link counters")).collect();
        println!("figure: {run} the restart, the vehicle's link counters: {counters:#?}");
        assert!(
            flight.kestrel_log.contains("signing timestamp stored at shutdown"),
            "{run}: {}",
            tail(&flight.kestrel_log, 20)
        );
    }
    println!("figure: both runs took {:.1} s", started.elapsed().as_secs_f64());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn mavproxy_identifies_the_vehicle_fetches_parameters_and_flies_it() {
    let dir = temp_dir("mavproxy");
    let flight = fly(&dir, "mavproxy", "mavproxy_session.py", &[], |port| link_params(port, "", ""));
    let printed = |needle: &str| flight.transcript.iter().any(|l| l.contains(&format!("mavproxy| {needle}")));
    // The config's table plus whatever the actors declare: at least the config's, fetched as
    // the packed parameter file over MAVLink FTP (MAVProxy says "Received N parameters (ftp)").
    let received = flight.transcript.iter().find_map(|l| {
        let rest = l.split("mavproxy| Received ").nth(1)?;
        let (count, how) = rest.split_once(" parameters")?;
        Some((count.parse::<usize>().ok()?, how.trim().to_owned()))
    });
    let listed = PARAM_TABLE.matches("name =").count();
    assert!(
        received.as_ref().is_some_and(|(n, how)| *n >= listed && how == "(ftp)"),
        "MAVProxy received {received:?} parameters, not ≥ {listed} over FTP"
    );
    for needed in [
        "Detected vehicle 1:1 on link 0",
        "Mode GUIDED", // no radio in the graph: it boots in GUIDED
        "RTL_ALT_M = 21.0000000",
        "Got COMMAND_ACK: COMPONENT_ARM_DISARM: ACCEPTED",
        "ARMED",
        "Got COMMAND_ACK: NAV_TAKEOFF: ACCEPTED",
        "Mode RTL",
        "DISARMED",
    ] {
        assert!(printed(needed), "MAVProxy never printed {needed:?}: {:#?}", flight.transcript);
    }
    assert!(flight.landed(), "{:#}", flight.report);
    std::fs::remove_dir_all(&dir).ok();
}

/// Two pseudo-terminals joined by `socat`, as a pair of radios joins a vehicle and a ground
/// station; the paths are symlinks socat makes in `dir`.
fn socat_pair(dir: &Path) -> (Proc, PathBuf, PathBuf) {
    let (vehicle, gcs) = (dir.join("vehicle-tty"), dir.join("gcs-tty"));
    let socat = Command::new("socat")
        .arg("-d")
        .arg("-d")
        .arg(format!("pty,raw,echo=0,link={}", vehicle.display()))
        .arg(format!("pty,raw,echo=0,link={}", gcs.display()))
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("start socat (Debian package socat; scripts/setup.sh installs it)");
    let socat = Proc(socat);
    let started = Instant::now();
    while !(vehicle.exists() && gcs.exists()) {
        assert!(started.elapsed() < Duration::from_secs(5), "socat made no pseudo-terminals");
        std::thread::sleep(Duration::from_millis(20));
    }
    (socat, vehicle, gcs)
}

#[test]
fn a_ground_station_flies_the_square_mission_over_a_57600_baud_serial_link() {
    let dir = temp_dir("serial");
    let (_socat, vehicle_tty, gcs_tty) = socat_pair(&dir);
    let plan = root().join("config/missions/square.plan");
    let gcs_tty = gcs_tty.to_str().expect("utf-8 path");
    let env = [("GCS_SERIAL", gcs_tty), ("GCS_BAUD", "57600")];
    let flight =
        fly_with_env(&dir, "serial", "gcs_flight.py", &[plan.to_str().expect("utf-8 path")], &env, |_| {
            sim_config(&format!(
                "params.system_id = 1\n\
                 params.endpoints = [ {{ type = \"serial\", device = \"{}\", baud = 57600 }} ]\n\
                 params.params = {PARAM_TABLE}\n",
                vehicle_tty.display()
            ))
        });
    let result = flight.transcript.last().expect("result");
    for needed in ["\"downloaded_identical\": true", "\"RTL\"", "\"reached\": [1, 2, 3, 4, 5"] {
        assert!(result.contains(needed), "{needed} not in {result}");
    }
    assert!(flight.landed(), "{:#}", flight.report);
    let serial_stats = flight
        .kestrel_log
        .lines()
        .find(|l| l.contains("MAVLink link counters") && l.contains("link=serial "))
        .unwrap_or("(closed before the counters were logged)");
    println!("kestrel's serial link: {serial_stats}");
    std::fs::remove_dir_all(&dir).ok();
}
