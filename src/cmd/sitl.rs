//! `kestrel sitl ardupilot`: ArduCopter SITL flying on Kestrel's simulator, through ArduPilot's
//! JSON physics protocol (`kestrel_sim::ardupilot`).
//!
//! Binds the physics port SITL instance N sends to (9002 + 10·N), then starts the `arducopter`
//! binary (`KESTREL_ARDUCOPTER`, else the config's `arducopter`) as `--model JSON:127.0.0.1`
//! with ArduPilot's autotest defaults (`copter.parm` beside the binary) and the config's
//! parameter files, at the world's home, its serial 0 sending MAVLink where `gcs` says. The
//! physics then answers SITL frame by frame until SITL exits, `--duration` of physics time has
//! passed, or SIGINT/SIGTERM/SIGHUP; then SITL is stopped and what the simulator saw (frames,
//! collisions, least clearance, landed, where) is printed as one JSON line, and written to
//! `--summary` if given, with the truth flown to `--trace` (tests/sitl_side_by_side.rs scores
//! ArduCopter's flight on it). Held by tests/sitl_ardupilot.rs.

use std::fs::File;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use kestrel_sim::ardupilot::{JsonBackend, JsonServer, SitlConfig, Summary, config::ARDUCOPTER_ENV};
use kestrel_sim::{RigidBodyState, VehicleParams, World};

/// Period of the truth trace (`--trace`, s of physics time): 20 Hz, finer than ArduCopter's
/// telemetry and the path's corners need.
const TRACE_PERIOD_S: f64 = 0.05;

/// `kestrel sitl ...`.
#[derive(Debug, clap::Args)]
pub struct SitlArgs {
    #[command(subcommand)]
    pub target: SitlTarget,
}

/// Which SITL to fly on the simulator.
#[derive(Debug, clap::Subcommand)]
pub enum SitlTarget {
    /// ArduCopter SITL on Kestrel's physics (its JSON physics backend).
    Ardupilot(ArdupilotArgs),
    /// One flight by Kestrel's own stack and by ArduCopter SITL on Kestrel's physics, scored
    /// alike on the simulator's truth; prints the two table rows of docs' side-by-side page.
    Compare(CompareArgs),
}

#[derive(Debug, clap::Args)]
pub struct CompareArgs {
    /// The mission (QGroundControl `.plan`): take-off, waypoints, then RTL or LAND.
    #[arg(long, value_name = "FILE.plan")]
    pub mission: PathBuf,
    /// The world both stacks fly in (wind, obstacles, `[[faults]]`).
    #[arg(long, value_name = "FILE")]
    pub world: PathBuf,
    /// Kestrel's vehicle file; ArduCopter flies the same airframe on the JSON backend.
    #[arg(long, default_value = "config/vehicles/quad_x.toml", value_name = "FILE")]
    pub vehicle: PathBuf,
    /// ArduCopter's parameter file for the frame (config/ardupilot/side-by-side.parm follows it).
    #[arg(long, default_value = "config/ardupilot/quad-x.parm", value_name = "FILE")]
    pub parm: PathBuf,
    /// Count the world's `[[faults]]` `at_s` from take-off for both stacks (ArduCopter takes off
    /// after EKF3's GPS wait, at no time known in advance); Kestrel's take-off time is measured by
    /// a fault-free flight first.
    #[arg(long)]
    pub faults_from_take_off: bool,
    /// The row's name in the table.
    #[arg(long, default_value = "this flight")]
    pub name: String,
    /// The repository (config/, tests/python/ardupilot_square.py).
    #[arg(long, default_value = ".", value_name = "DIR")]
    pub repo: PathBuf,
    /// The Python with pymavlink that flies ArduCopter; default the repository's `.venv`, else
    /// `python3`.
    #[arg(long, value_name = "FILE")]
    pub python: Option<PathBuf>,
    /// The ArduCopter SITL binary, when `KESTREL_ARDUCOPTER` is unset.
    #[arg(long, value_name = "FILE")]
    pub arducopter: Option<PathBuf>,
    /// Print the ground station's transcript as it comes.
    #[arg(long)]
    pub verbose: bool,
}

#[derive(Debug, clap::Args)]
pub struct ArdupilotArgs {
    /// The SITL config (TOML): vehicle, world, binary, parameter files.
    #[arg(long, short, default_value = "config/ardupilot/sitl.toml", value_name = "FILE")]
    pub config: PathBuf,
    /// Where SITL's serial 0 sends MAVLink, overriding the config's `gcs`
    /// (e.g. `udpclient:127.0.0.1:14550`).
    #[arg(long, value_name = "SPEC")]
    pub gcs: Option<String>,
    /// SITL instance (`-I`), overriding the config's `instance`.
    #[arg(long, value_name = "N")]
    pub instance: Option<u16>,
    /// Stop after this much physics time (s).
    #[arg(long, value_name = "S")]
    pub duration: Option<f64>,
    /// Write the run's summary (JSON) here too.
    #[arg(long, value_name = "FILE.json")]
    pub summary: Option<PathBuf>,
    /// Fly this world file instead of the config's (wind, obstacles, `[[faults]]`).
    #[arg(long, value_name = "FILE")]
    pub world: Option<PathBuf>,
    /// Count the world's `[[faults]]` `at_s` from the vehicle's take-off instead of from the
    /// start: ArduCopter leaves the ground after EKF3's GPS wait and a ground station's commands,
    /// at no time known in advance.
    #[arg(long)]
    pub faults_from_take_off: bool,
    /// Write the truth the simulator flew (JSON: a sample every 0.05 s of physics time: time,
    /// position, velocity, attitude, landed, battery voltage and current) here at the end.
    #[arg(long, value_name = "FILE.json")]
    pub trace: Option<PathBuf>,
    /// SITL's working directory (its eeprom.bin and logs/ stay there); default a temporary one,
    /// removed at the end.
    #[arg(long, value_name = "DIR")]
    pub dir: Option<PathBuf>,
}

pub fn run(args: SitlArgs) -> Result<(), String> {
    match args.target {
        SitlTarget::Ardupilot(args) => ardupilot(args),
        SitlTarget::Compare(args) => compare(args),
    }
}

fn compare(args: CompareArgs) -> Result<(), String> {
    use kestrel::side_by_side::{HEADER, Scenario, Tools, fly_row, row};
    let arducopter = std::env::var_os(ARDUCOPTER_ENV)
        .map(PathBuf::from)
        .or(args.arducopter)
        .ok_or_else(|| format!("no ArduCopter SITL binary: set {ARDUCOPTER_ENV} or give --arducopter"))?;
    let file = |p: &Path, what: &str| -> Result<PathBuf, String> {
        if p.is_file() { Ok(absolute(p)) } else { Err(format!("{what} {} is not a file", p.display())) }
    };
    let repo = absolute(&args.repo);
    let python = match args.python {
        Some(p) => file(&p, "--python")?,
        None => {
            Some(repo.join(".venv/bin/python")).filter(|p| p.is_file()).unwrap_or_else(|| "python3".into())
        }
    };
    let tools = Tools {
        kestrel: std::env::current_exe().map_err(|e| format!("this program's path: {e}"))?,
        arducopter: file(&arducopter, "ArduCopter SITL binary")?,
        python,
        repo: repo.clone(),
        echo_transcript: args.verbose,
    };
    file(&repo.join("tests/python/ardupilot_square.py"), "--repo's ground station script")?;
    let scenario = Scenario {
        name: args.name,
        plan: file(&args.mission, "--mission")?,
        world: file(&args.world, "--world")?,
        vehicle: file(&args.vehicle, "--vehicle")?,
        parm: file(&args.parm, "--parm")?,
        faults_from_take_off: args.faults_from_take_off,
    };
    let dir = std::env::temp_dir().join(format!("kestrel-sitl-compare-{}", std::process::id()));
    let flown = fly_row(&tools, &scenario, &dir, None);
    let _ = std::fs::remove_dir_all(&dir);
    let (kestrel, arducopter) = flown?;
    println!("{HEADER}");
    println!("{}", row(&scenario.name, "Kestrel", &kestrel.score));
    println!("{}", row(&scenario.name, "ArduCopter", &arducopter.score));
    tracing::info!(
        "wall time: Kestrel {:.1} s, ArduCopter {:.1} s (in parallel)",
        kestrel.wall_s,
        arducopter.wall_s
    );
    Ok(())
}

fn ardupilot(args: ArdupilotArgs) -> Result<(), String> {
    let mut config = SitlConfig::load(&args.config).map_err(|e| e.to_string())?;
    if let Some(gcs) = args.gcs {
        config.gcs = gcs;
    }
    if let Some(instance) = args.instance {
        config.instance = instance;
    }
    if let Some(world) = &args.world {
        config.world = world.clone();
    }
    config.validate().map_err(|e| format!("{}: {e}", args.config.display()))?;
    if let Some(d) = args.duration
        && !(d.is_finite() && d > 0.0)
    {
        return Err(format!("--duration {d}: must be a positive number of seconds"));
    }
    let binary = config.binary().ok_or_else(|| {
        format!(
            "no ArduCopter SITL binary: set {ARDUCOPTER_ENV} or `arducopter` in {}",
            args.config.display()
        )
    })?;
    if !binary.is_file() {
        return Err(format!("ArduCopter SITL binary {} is not a file", binary.display()));
    }
    let autotest_defaults = binary.with_file_name("copter.parm");
    if !autotest_defaults.is_file() {
        return Err(format!("no {} beside the ArduCopter binary", autotest_defaults.display()));
    }
    for parm in &config.defaults {
        if !parm.is_file() {
            return Err(format!("{}: parameter file {} not found", args.config.display(), parm.display()));
        }
    }

    let vehicle = VehicleParams::load(&config.vehicle).map_err(|e| e.to_string())?;
    let world = World::load(&config.world).map_err(|e| e.to_string())?;
    let home = world.home.clone();
    let new =
        if args.faults_from_take_off { JsonBackend::with_faults_from_take_off } else { JsonBackend::new };
    let mut backend = new(vehicle, world, config.seed, config.frame_rate_hz, RigidBodyState::default())
        .map_err(|e| format!("{}: {e}", args.config.display()))?;
    if args.trace.is_some() {
        backend.trace_every(TRACE_PERIOD_S).map_err(|e| e.to_string())?;
    }
    let mut server = JsonServer::bind(backend, config.instance)
        .map_err(|e| format!("physics port of SITL instance {}: {e}", config.instance))?;

    let keep_dir = args.dir.is_some();
    let dir = args.dir.unwrap_or_else(|| {
        std::env::temp_dir().join(format!(
            "kestrel-sitl-ardupilot-{}-{}",
            std::process::id(),
            config.instance
        ))
    });
    std::fs::create_dir_all(&dir).map_err(|e| format!("SITL directory {}: {e}", dir.display()))?;
    let defaults: Vec<String> = std::iter::once(&autotest_defaults)
        .chain(&config.defaults)
        .map(|p| absolute(p).display().to_string())
        .collect();
    let home_arg = format!("{},{},{},0", home.lat_deg, home.lon_deg, home.alt_msl_m);
    let mut sitl = start_sitl(&binary, &dir, &config, &defaults.join(","), &home_arg)?;
    tracing::info!(
        "ArduCopter SITL instance {} (pid {}) on Kestrel's physics at {} Hz; MAVLink to {}; in {}",
        config.instance,
        sitl.id(),
        config.frame_rate_hz,
        config.gcs,
        dir.display()
    );

    let signalled = watch_signals();
    let duration_s = args.duration.unwrap_or(f64::INFINITY);
    let mut sitl_exit = None;
    let served = server.serve(|summary: &Summary| {
        if let Ok(Some(status)) = sitl.try_wait() {
            sitl_exit = Some(status);
        }
        sitl_exit.is_some() || summary.time_s >= duration_s || signalled.load(Ordering::Relaxed)
    });
    let _ = sitl.kill();
    let _ = sitl.wait();
    let summary = served.map_err(|e| format!("physics port: {e}"))?;
    let line = serde_json::to_string(&summary).map_err(|e| e.to_string())?;
    println!("{line}");
    if let Some(path) = &args.summary {
        std::fs::write(path, format!("{line}\n")).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    if let Some(path) = &args.trace {
        let trace = serde_json::to_string(server.backend().trace()).map_err(|e| e.to_string())?;
        std::fs::write(path, trace).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    if !keep_dir {
        let _ = std::fs::remove_dir_all(&dir);
    }
    match sitl_exit {
        Some(status) if !status.success() => Err(format!("ArduCopter SITL exited with {status}")),
        _ => Ok(()),
    }
}

fn start_sitl(
    binary: &Path,
    dir: &Path,
    config: &SitlConfig,
    defaults: &str,
    home: &str,
) -> Result<Child, String> {
    let log_path = dir.join("arducopter.log");
    let log = File::create(&log_path).map_err(|e| format!("{}: {e}", log_path.display()))?;
    let err = log.try_clone().map_err(|e| e.to_string())?;
    let mut command = Command::new(binary);
    command
        .current_dir(dir)
        .args(["--model", "JSON:127.0.0.1", "--speedup", &config.speedup.to_string(), "--defaults", defaults])
        .args(["--home", home, "-w", "-I", &config.instance.to_string(), "--serial0", &config.gcs])
        .stdin(Stdio::null())
        .stdout(log)
        .stderr(err);
    // SAFETY: prctl is async-signal-safe and touches no memory of the parent; it makes the
    // kernel kill SITL when this process dies, so a killed `kestrel sitl` never leaves an
    // orphan SITL waiting for physics that will not come.
    unsafe {
        command.pre_exec(|| {
            if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL) == 0 {
                Ok(())
            } else {
                Err(std::io::Error::last_os_error())
            }
        });
    }
    command.spawn().map_err(|e| format!("start {}: {e}", binary.display()))
}

/// `path` made absolute against the working directory (SITL runs in its own).
fn absolute(path: &Path) -> PathBuf {
    std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf())
}

/// A flag set by the first SIGINT, SIGTERM or SIGHUP.
fn watch_signals() -> Arc<AtomicBool> {
    let flag = Arc::new(AtomicBool::new(false));
    let set = flag.clone();
    std::thread::spawn(move || {
        let Ok(runtime) = tokio::runtime::Builder::new_current_thread().enable_io().build() else {
            return;
        };
        runtime.block_on(async {
            use tokio::signal::unix::{SignalKind, signal};
            let (Ok(mut term), Ok(mut int), Ok(mut hup)) = (
                signal(SignalKind::terminate()),
                signal(SignalKind::interrupt()),
                signal(SignalKind::hangup()),
            ) else {
                return;
            };
            tokio::select! {
                _ = term.recv() => {}
                _ = int.recv() => {}
                _ = hup.recv() => {}
            }
            set.store(true, Ordering::Relaxed);
        });
    });
    flag
}
