//! ArduCopter SITL as the reference vehicle: a test runs the same pymavlink script against it
//! and against `kestrel run` and compares what each reports ("as ArduCopter does", checked).
//!
//! The binary is the one `KESTREL_ARDUCOPTER` names (`.ci/run` sets it to
//! `../shared/ardupilot/arducopter` when that exists; its README says how it was built). When
//! the variable is unset, [`binary`] says so on stdout and returns `None`, and the caller runs
//! its Kestrel half alone.
//!
//! Each [`ArduCopter`] runs `arducopter --model + --speedup N --defaults copter.parm --home
//! HOME -w -I INSTANCE --serial0 udpclient:127.0.0.1:PORT` from a scratch directory of its own
//! (it writes `eeprom.bin`, `logs/`, `terrain/` there), its telemetry going to the UDP port the
//! client listens on. The instance number is one no other test (nor anything else on the host)
//! holds: a lock file per instance in the temp dir, held while the vehicle runs, and the ports
//! SITL opens for the instance (TCP 5762/5763 + 10·N, UDP 5501 + 10·N) found free. The process
//! is killed, and its directory removed, when the value is dropped.
//!
//! Uses `sim_vehicle` (the Python venv and child processes): a test binary that declares
//! `mod arducopter;` declares `mod sim_vehicle;` beside it.

use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use super::sim_vehicle::{Proc, python_client, tail, transcript_until_exit};

/// The environment variable naming the ArduCopter SITL binary.
pub const ENV: &str = "KESTREL_ARDUCOPTER";
/// Where SITL starts: latitude, longitude (deg), altitude AMSL (m), heading (deg) — Kestrel's
/// simulated home (config/worlds), so the same script's waypoints mean the same to both.
pub const HOME: &str = "6.79710,79.90170,20,0";
/// Simulated seconds per wall second. ArduCopter needs about 40 s of simulated time before
/// EKF3 uses GPS and it can arm: 4 to 5 s of wall time at 10, which a 2-core host shared with
/// other builds keeps up with (at 20 SITL falls behind its own clock under load).
pub const SPEEDUP: u32 = 10;
/// Instances tried, from 1 (0 is the one a person runs by hand, on the default ports).
const INSTANCES: std::ops::RangeInclusive<u16> = 1..=60;

/// The SITL binary `KESTREL_ARDUCOPTER` names, or `None` (said on stdout) when it is unset.
/// Panics when it is set to something that does not exist: a misconfigured CI must fail, not
/// skip.
pub fn binary() -> Option<PathBuf> {
    let Some(path) = std::env::var_os(ENV) else {
        println!(
            "{ENV} is not set: the ArduCopter SITL half of this test is SKIPPED (set it to the arducopter binary, e.g. /work/shared/ardupilot/arducopter)"
        );
        return None;
    };
    let path = PathBuf::from(path);
    assert!(path.is_file(), "{ENV}={} is not a file", path.display());
    Some(path)
}

/// A running ArduCopter SITL; killed when dropped.
pub struct ArduCopter {
    process: Proc,
    dir: PathBuf,
    /// `-I`: its ports are the defaults + 10 × this.
    pub instance: u16,
    /// Held while the vehicle runs: no other harness takes the instance.
    _lock: File,
}

impl ArduCopter {
    /// Starts `binary` at [`SPEEDUP`] with ArduPilot's own autotest defaults (`copter.parm`
    /// beside the binary) and a wiped EEPROM, its serial 0 sending MAVLink to
    /// 127.0.0.1:`gcs_port` (UDP).
    pub fn start(binary: &Path, gcs_port: u16) -> ArduCopter {
        ArduCopter::start_model(binary, gcs_port, "+", None, &[])
    }

    /// As [`ArduCopter::start`], on SITL's built-in physics for `frame` (`--model`, e.g. `x`)
    /// with the frame's mass, thrust and inertia from `frame_json` (SIM_Frame's model file,
    /// copied into SITL's directory: it loads the file by a relative path only) and `parms` after
    /// `copter.parm` in `--defaults`.
    pub fn start_model(
        binary: &Path,
        gcs_port: u16,
        frame: &str,
        frame_json: Option<&Path>,
        parms: &[&Path],
    ) -> ArduCopter {
        ArduCopter::start_at(binary, gcs_port, frame, frame_json, parms, SPEEDUP)
    }

    /// As [`ArduCopter::start_model`], at `speedup` simulated seconds per wall second.
    pub fn start_at(
        binary: &Path,
        gcs_port: u16,
        frame: &str,
        frame_json: Option<&Path>,
        parms: &[&Path],
        speedup: u32,
    ) -> ArduCopter {
        let copter_parm = binary.with_file_name("copter.parm");
        assert!(copter_parm.is_file(), "no {} beside the ArduCopter binary", copter_parm.display());
        let defaults = std::iter::once(copter_parm.as_path())
            .chain(parms.iter().copied())
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(",");
        let (instance, lock) = free_instance();
        let dir = std::env::temp_dir().join(format!("kestrel-arducopter-{}-{instance}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("SITL's scratch dir");
        let model = match frame_json {
            Some(json) => {
                std::fs::copy(json, dir.join("frame.json")).expect("copy the frame model");
                format!("{frame}:frame.json")
            }
            None => frame.to_string(),
        };
        let log = File::create(dir.join("arducopter.log")).expect("SITL log");
        let process = Proc(
            Command::new(binary)
                .current_dir(&dir)
                .args(["--model", &model, "--speedup", &speedup.to_string(), "--defaults"])
                .arg(&defaults)
                .args(["--home", HOME, "-w", "-I", &instance.to_string(), "--serial0"])
                .arg(format!("udpclient:127.0.0.1:{gcs_port}"))
                .stdin(Stdio::null())
                .stdout(log.try_clone().expect("log"))
                .stderr(log)
                .spawn()
                .unwrap_or_else(|e| panic!("start {}: {e}", binary.display())),
        );
        ArduCopter { process, dir, instance, _lock: lock }
    }

    /// The last `lines` lines SITL printed (for a failure message).
    pub fn log_tail(&self, lines: usize) -> String {
        tail(&std::fs::read_to_string(self.dir.join("arducopter.log")).unwrap_or_default(), lines)
    }

    /// Whether SITL is still running.
    pub fn running(&mut self) -> bool {
        matches!(self.process.0.try_wait(), Ok(None))
    }
}

impl Drop for ArduCopter {
    fn drop(&mut self) {
        let _ = self.process.0.kill();
        let _ = self.process.0.wait();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// An instance number whose lock this process now holds and whose ports are free (its JSON
/// physics port, UDP 9002 + 10·N, included).
pub fn free_instance() -> (u16, File) {
    for n in INSTANCES {
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
            return (n, file);
        }
    }
    panic!("no free ArduCopter SITL instance in {INSTANCES:?}");
}

/// How long one scripted session against SITL may take on the wall clock.
const CLIENT_LIMIT: Duration = Duration::from_secs(150);

/// Runs the Python client `tests/python/SCRIPT` (with `env`) against ArduCopter SITL started
/// on the UDP port the client reports on its first line (`PORT n`), as `sim_vehicle::
/// scripted_session` does against `kestrel run`; waits for the client to exit 0 and returns the
/// JSON of its last line. The transcript is printed (`--nocapture`); on failure, with SITL's
/// output.
pub fn scripted_session(binary: &Path, script: &str, env: &[(&str, String)]) -> serde_json::Value {
    scripted_session_at(binary, script, env, SPEEDUP)
}

/// As [`scripted_session`], SITL at `speedup`: for a client that keeps up only with a slower
/// vehicle, such as MAVProxy.
pub fn scripted_session_at(
    binary: &Path,
    script: &str,
    env: &[(&str, String)],
    speedup: u32,
) -> serde_json::Value {
    let (mut client, lines) = python_client(script, |c| c.envs(env.iter().map(|(k, v)| (k, v))));
    let first = lines.recv_timeout(Duration::from_secs(15)).unwrap_or_default();
    let port: u16 = first.strip_prefix("PORT ").and_then(|p| p.trim().parse().ok()).expect("client port");
    let started = Instant::now();
    let mut sitl = ArduCopter::start_at(binary, port, "+", None, &[], speedup);
    println!("── {script} against ArduCopter SITL (instance {}, speed-up {speedup}) ──", sitl.instance);
    let (exit, transcript) =
        transcript_until_exit(&mut client, &lines, || started.elapsed() > CLIENT_LIMIT || !sitl.running());
    assert!(
        exit.is_some_and(|s| s.success()),
        "{script} against ArduCopter: client {exit:?}\nSITL:\n{}",
        sitl.log_tail(30)
    );
    println!("{script} against ArduCopter took {:.1} s", started.elapsed().as_secs_f64());
    let last = transcript.last().expect("a result line");
    serde_json::from_str(last)
        .unwrap_or_else(|e| panic!("{script}: the last line is no JSON result ({e}): {last}"))
}
