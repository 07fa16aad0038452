//! The same flight with both stacks, one table row: a mission (QGC `.plan`), a world and a
//! vehicle flown by Kestrel's own stack in the lockstep simulator (`kestrel run --auto`) and by
//! ArduCopter SITL on the same simulator (`kestrel sitl ardupilot`, a ground station script
//! arming it), both scored the same way on the simulator's truth ([`score`]). `kestrel sitl
//! compare` flies one row and prints it; tests/sitl_side_by_side.rs flies the results page's rows
//! with the same code.
//!
//! * [`score`]: the scoring, pure;
//! * [`kestrel_flight`]: Kestrel's side, with ArduCopter SITL's sensor defaults;
//! * [`arducopter_flight`]: ArduCopter's side, through tests/python/ardupilot_square.py.
//!
//! Both sides fly seed [`SEED`]: a world whose gusts run from take-off
//! (`[wind] gusts_from_take_off`) gives both the same gust series.

pub mod arducopter_flight;
pub mod kestrel_flight;
pub mod score;

use std::path::{Path, PathBuf};
use std::time::Duration;

pub use arducopter_flight::{fly_arducopter, free_instance};
pub use kestrel_flight::{ardupilot_sensor_defaults, fly_kestrel};
pub use score::{Estimate, PlannedPath, Score, Truth, score};

/// The simulator seed of both sides: config/sim.toml's.
pub const SEED: u64 = 1;

/// Wall time one ArduCopter flight may take, EKF3's GPS wait included.
pub const ARDUCOPTER_LIMIT: Duration = Duration::from_secs(150);

/// One row of the comparison: what to fly, and where. Paths are as given (absolute, or relative
/// to the working directory).
#[derive(Clone, Debug)]
pub struct Scenario {
    /// The row's name in the table.
    pub name: String,
    /// The QGC plan.
    pub plan: PathBuf,
    /// The world file.
    pub world: PathBuf,
    /// Kestrel's vehicle file (ArduCopter flies the same through the JSON backend).
    pub vehicle: PathBuf,
    /// ArduCopter's parameter file for the frame (config/ardupilot/*.parm);
    /// config/ardupilot/side-by-side.parm follows it.
    pub parm: PathBuf,
    /// The world's `[[faults]]` count from take-off for both stacks: ArduCopter leaves the ground
    /// after EKF3's GPS wait and a ground station's commands, at no time known in advance.
    pub faults_from_take_off: bool,
}

/// The programs a row runs.
#[derive(Clone, Debug)]
pub struct Tools {
    /// The `kestrel` binary (`kestrel run`, `kestrel sitl ardupilot`).
    pub kestrel: PathBuf,
    /// The ArduCopter SITL binary (`copter.parm` beside it).
    pub arducopter: PathBuf,
    /// The Python with pymavlink that runs the ground station script.
    pub python: PathBuf,
    /// The repository: config/ and tests/python/.
    pub repo: PathBuf,
    /// Print the ground station's transcript as it comes.
    pub echo_transcript: bool,
}

/// What one side of a row flew.
#[derive(Clone, Debug)]
pub struct Flown {
    pub score: Score,
    /// Wall time of the run (s), for the log only.
    pub wall_s: f64,
}

/// Flies `scenario` with both stacks at once, in scratch directories under `dir` (removed once
/// scored), and returns Kestrel's flight, then ArduCopter's. Kestrel's faults are moved by
/// `kestrel_fault_offset_s` when they count from take-off (Kestrel's take-off time on the same
/// plan); `None` measures it with a fault-free Kestrel flight first.
pub fn fly_row(
    tools: &Tools,
    scenario: &Scenario,
    dir: &Path,
    kestrel_fault_offset_s: Option<f64>,
) -> Result<(Flown, Flown), String> {
    let scratch = |stack: &str| -> Result<PathBuf, String> {
        let slug: String =
            scenario.name.chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '-' }).collect();
        let d = dir.join(format!("{slug}-{stack}"));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).map_err(|e| format!("{}: {e}", d.display()))?;
        Ok(d)
    };
    let (kestrel_dir, arducopter_dir) = (scratch("kestrel")?, scratch("arducopter")?);
    let (kestrel, ardupilot) = std::thread::scope(|s| {
        let ardupilot = s.spawn(|| fly_arducopter(tools, scenario, &arducopter_dir, ARDUCOPTER_LIMIT));
        let offset_s = match (scenario.faults_from_take_off, kestrel_fault_offset_s) {
            (false, _) => Ok(0.0),
            (true, Some(offset_s)) => Ok(offset_s),
            // The same flight with the world's faults moved past its end: Kestrel's take-off time.
            (true, None) => scratch("kestrel-take-off").and_then(|dir| {
                let plain = fly_kestrel(tools, scenario, &dir, NEVER_S);
                let _ = std::fs::remove_dir_all(&dir);
                plain.map(|f| f.score.take_off_s)
            }),
        };
        let kestrel = offset_s.and_then(|offset_s| fly_kestrel(tools, scenario, &kestrel_dir, offset_s));
        let ardupilot = ardupilot
            .join()
            .unwrap_or_else(|_| Err(format!("{}: ArduCopter's flight panicked", scenario.name)));
        (kestrel, ardupilot)
    });
    let (kestrel, ardupilot) = (kestrel?, ardupilot?);
    let _ = std::fs::remove_dir_all(&kestrel_dir);
    let _ = std::fs::remove_dir_all(&arducopter_dir);
    Ok((kestrel, ardupilot))
}

/// A fault offset no flight reaches (s): the faults of a take-off-measuring flight.
const NEVER_S: f64 = 1e6;

/// `x` rounded to a multiple of `step`, printed with `decimals`; `–` when not finite.
fn round_to(x: f64, step: f64, decimals: usize) -> String {
    if !x.is_finite() {
        return "–".into();
    }
    let r = (x / step).round() * step;
    // No "-0.0".
    let r = if r == 0.0 { 0.0 } else { r };
    format!("{r:.decimals$}")
}

/// The table's header (two lines, Markdown).
pub const HEADER: &str = "| Flight | Stack | Tracking RMS / worst (m) | Position estimate RMS horizontal / vertical (m) \
                          | Velocity estimate RMS (m/s) | Attitude estimate RMS roll-pitch / yaw (°) \
                          | Take-off to touchdown (s) | Landing error (m) | Energy (Wh) | Outcome |\n\
                          |---|---|---|---|---|---|---|---|---|---|";

/// One table row (Markdown) of `stack`'s flight of `scenario`.
pub fn row(scenario: &str, stack: &str, s: &Score) -> String {
    format!(
        "| {scenario} | {stack} | {} / {} | {} / {} | {} | {} / {} | {} | {} | {} | {} |",
        round_to(s.tracking_rms_m, 0.01, 2),
        round_to(s.tracking_max_m, 0.01, 2),
        round_to(s.est_horizontal_rms_m, 0.01, 2),
        round_to(s.est_vertical_rms_m, 0.01, 2),
        round_to(s.est_velocity_rms_m_s, 0.01, 2),
        round_to(s.est_roll_pitch_rms_deg, 0.01, 2),
        round_to(s.est_yaw_rms_deg, 0.01, 2),
        round_to(s.flight_s, 0.1, 1),
        round_to(s.landing_error_m, 0.01, 2),
        round_to(s.energy_wh, 0.01, 2),
        s.outcome,
    )
}
