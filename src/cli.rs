//! The command line: `kestrel run` and its flags.

use std::path::PathBuf;

use clap::{Parser, Subcommand};

/// Kestrel: an open flight stack for multirotors on a Linux companion computer.
///
/// With no hardware attached, `kestrel run` flies the whole graph against the built-in
/// simulator (config/sim.toml).
#[derive(Debug, Parser)]
#[command(name = "kestrel", version, about, long_about = None)]
pub struct Cli {
    /// Log level (error, warn, info, debug, trace) or a tracing filter such as
    /// `info,kestrel::status=warn`; the RUST_LOG environment variable takes precedence.
    #[arg(long, global = true, default_value = "info", value_name = "FILTER")]
    pub log_level: String,

    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run an actor graph: the full vehicle on the simulator by default.
    Run(RunArgs),
    /// Evaluate a fuzzy rule base (fuzzylite .fll or Kestrel .toml).
    Fuzzy(FuzzyArgs),
    /// Run the estimator over a recorded flight (PX4 .ulg or Kestrel .mcap) and write its
    /// estimate beside the log's own as CSV.
    Replay(ReplayArgs),
    /// Calibrate a stereo camera from chessboard image pairs (OpenCV-compatible YAML out).
    Calibrate(CalibrateArgs),
    /// Compute the disparity of a stereo pair; with ground truth, print its error figures.
    Disparity(DisparityArgs),
    /// Run frame → depth grid on a stereo source; print grids and per-stage timings.
    Stereo(StereoArgs),
    /// Plots (PNG) and an error summary of a recorded flight (`kestrel run --record`).
    Report(crate::cmd::report::ReportArgs),
    /// Fly another flight stack's SITL on Kestrel's simulator (`kestrel sitl ardupilot`).
    Sitl(crate::cmd::sitl::SitlArgs),
}

#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// Graph config (TOML): which actors run and how they are wired.
    #[arg(long, short, default_value = "config/sim.toml", value_name = "FILE")]
    pub config: PathBuf,

    /// Stop after this many seconds of graph time (simulated time under lockstep).
    #[arg(long, value_name = "S")]
    pub duration: Option<f64>,

    /// Lockstep pacing: simulated seconds per wall-clock second; 0 runs as fast as possible.
    #[arg(long, value_name = "N")]
    pub speedup: Option<f64>,

    /// Record the topics selected in the config's [record] table to this MCAP file.
    #[arg(long, value_name = "FILE.mcap")]
    pub record: Option<PathBuf>,

    /// The vehicle's log directory (overrides `[record] dir`): a numbered log per arming,
    /// served to ground stations by MAVLink log download and FTP.
    #[arg(long, value_name = "DIR")]
    pub log_dir: Option<PathBuf>,

    /// Load this QGroundControl mission (`.plan`) into the commander.
    #[arg(long, value_name = "FILE.plan")]
    pub mission: Option<PathBuf>,

    /// Arm, take off and fly the mission as soon as the pre-arm checks pass.
    #[arg(long)]
    pub auto: bool,

    /// End the run once the vehicle has flown, landed and disarmed.
    #[arg(long)]
    pub exit_on_land: bool,

    /// Write the flight report (JSON: mission, collisions, estimator error against ground
    /// truth, control-loop timing, failsafes) to this file when the run ends.
    #[arg(long, value_name = "FILE.json")]
    pub report: Option<PathBuf>,

    /// Do not print the once-a-second status line.
    #[arg(long)]
    pub quiet: bool,

    /// Print the graph with every base it `extends` merged in (TOML), and exit.
    #[arg(long)]
    pub print_config: bool,

    /// Print the graph's wiring as a Graphviz DOT picture (each actor a box, each arrow the
    /// topics one actor reads from another), and exit: `kestrel run --print-graph | dot -Tsvg`.
    /// With `--hil`, the graph as it runs on the emulated board.
    #[arg(long)]
    pub print_graph: bool,

    /// Which of several vehicles on this machine to be, 0..=254 (PX4's multi-vehicle SITL):
    /// system id N+1, local ports 18570+N and 14580+N, API port 14540+N, the ground station
    /// still at 14550, and the simulated vehicle spawned 5·N m east of the others.
    #[arg(long, value_parser = clap::value_parser!(u8).range(0..=254))]
    pub instance: Option<u8>,

    /// Hardware in the loop: run the graph (config/navio2.toml) unchanged against an emulated
    /// Navio2 whose devices the simulator drives on the wall clock.
    #[arg(long)]
    pub hil: bool,

    /// With --hil: the simulated world (relative to the config's directory).
    #[arg(long, value_name = "FILE.toml", requires = "hil")]
    pub hil_world: Option<PathBuf>,
}

#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("source").required(true).args(["input", "csv"])))]
pub struct FuzzyArgs {
    /// Rule base: fuzzylite FLL (`.fll`) or Kestrel TOML (`.toml`).
    #[arg(long, value_name = "FILE")]
    pub rules: PathBuf,

    /// An input value, `NAME=VALUE`; give every input variable once.
    #[arg(long, value_name = "NAME=VALUE")]
    pub input: Vec<String>,

    /// Evaluate every row of a CSV whose header names the inputs; prints one row of outputs
    /// per input row.
    #[arg(long, value_name = "IN.csv", conflicts_with = "input")]
    pub csv: Option<PathBuf>,

    /// Print JSON (outputs and every rule's activation) instead of `NAME=VALUE` lines.
    #[arg(long)]
    pub json: bool,

    /// Also print each rule's activation degree, as `# DEGREE RULE` lines.
    #[arg(long)]
    pub activations: bool,
}

#[derive(Debug, clap::Args)]
pub struct ReplayArgs {
    /// The flight log: a PX4 ULog (`.ulg`) or a Kestrel MCAP log (`.mcap`).
    #[arg(long, value_name = "FILE")]
    pub log: PathBuf,

    /// Where to write the CSV (our estimate beside the log's estimate or ground truth).
    #[arg(long, value_name = "FILE.csv")]
    pub out: PathBuf,

    /// Estimator parameters (TOML, the estimator actor's `params` table); defaults otherwise.
    #[arg(long, value_name = "FILE.toml")]
    pub params: Option<PathBuf>,
}

#[derive(Debug, clap::Args)]
pub struct CalibrateArgs {
    /// Left images, a glob such as 'calib/left*.jpg' (pairs match in sorted name order).
    #[arg(long, value_name = "GLOB")]
    pub left: String,

    /// Right images, a glob such as 'calib/right*.jpg'.
    #[arg(long, value_name = "GLOB")]
    pub right: String,

    /// Inner corners of the chessboard, COLSxROWS.
    #[arg(long, default_value = "9x6", value_name = "COLSxROWS")]
    pub board: String,

    /// Side of one chessboard square (m).
    #[arg(long, default_value_t = 0.025, value_name = "M")]
    pub square: f64,

    /// A measured and a true distance to the same target (m), `MEASURED:TRUE`; several give
    /// the depth-scale correction stored in the file (thesis §3.2.5).
    #[arg(long, value_name = "MEASURED:TRUE")]
    pub reference: Vec<String>,

    /// Where to write the calibration (OpenCV FileStorage YAML).
    #[arg(long, value_name = "FILE.yaml")]
    pub out: PathBuf,
}

#[derive(Debug, clap::Args)]
pub struct DisparityArgs {
    /// Left image.
    #[arg(long, value_name = "FILE")]
    pub left: PathBuf,

    /// Right image.
    #[arg(long, value_name = "FILE")]
    pub right: PathBuf,

    /// Calibration (from `kestrel calibrate`) to rectify the pair with; without it the pair
    /// must already be rectified.
    #[arg(long, value_name = "FILE.yaml")]
    pub calib: Option<PathBuf>,

    /// Matcher parameters (TOML: `algorithm = "sgbm"` or `"bm"` and OpenCV's parameters);
    /// Kestrel's SGBM defaults otherwise.
    #[arg(long, value_name = "FILE.toml")]
    pub matcher: Option<PathBuf>,

    /// Disparity search range (px, a multiple of 16), overriding the matcher's.
    #[arg(long, value_name = "N")]
    pub num_disparities: Option<i32>,

    /// Ground-truth disparity image (Middlebury: 0 = unknown).
    #[arg(long, value_name = "FILE")]
    pub gt: Option<PathBuf>,

    /// Ground-truth value per pixel of disparity (Middlebury quarter-size sets: 4).
    #[arg(long, value_name = "S")]
    pub gt_scale: Option<f32>,

    /// Output: `.pfm` (Middlebury float, invalid = +inf) or `.png` (16-bit, value = d·256,
    /// 0 = invalid, KITTI's convention).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// Also write the depth as a colour PNG (viridis on inverse depth: yellow near, dark
    /// purple far, black = no depth). Needs the geometry: `--calib`, or `--focal-px` and
    /// `--baseline-m` for an already rectified pair.
    #[arg(long, value_name = "FILE.png")]
    pub depth_out: Option<PathBuf>,

    /// Depths the colour scale spans (m), `NEAR:FAR`; nearer is yellow, farther dark purple.
    #[arg(long, default_value = "0.5:20", value_name = "NEAR:FAR")]
    pub depth_range: String,

    /// Focal length of the rectified pair (px), for `--depth-out` without `--calib`.
    #[arg(long, value_name = "PX", requires = "baseline_m", conflicts_with = "calib")]
    pub focal_px: Option<f64>,

    /// Baseline of the rectified pair (m), for `--depth-out` without `--calib`.
    #[arg(long, value_name = "M", requires = "focal_px")]
    pub baseline_m: Option<f64>,

    /// Right minus left principal point column (px; Middlebury's `doffs`), with `--focal-px`.
    #[arg(long, value_name = "PX", default_value_t = 0.0, requires = "focal_px")]
    pub doffs_px: f64,
}

#[derive(Debug, clap::Args)]
pub struct StereoArgs {
    /// Where frames come from: a folder of image pairs (see --left, --right), two video files
    /// `LEFT,RIGHT`, or a side-by-side V4L2 camera `/dev/videoN` (see --size, --fps).
    #[arg(long, value_name = "SOURCE")]
    pub source: String,

    /// Stereo parameters: the stereo actor's `params` table (`geometry`, `pipeline`) as a TOML
    /// file, or a graph config whose one `stereo` actor's params are used.
    #[arg(long, value_name = "FILE.toml")]
    pub config: PathBuf,

    /// Left images in a folder source (`*`, `?` wildcards; pairs match in sorted name order).
    #[arg(long, default_value = "left*", value_name = "GLOB")]
    pub left: String,

    /// Right images in a folder source.
    #[arg(long, default_value = "right*", value_name = "GLOB")]
    pub right: String,

    /// Frame size of a side-by-side camera, both views together (the ZED's VGA mode is
    /// 1344x376).
    #[arg(long, default_value = "1344x376", value_name = "WIDTHxHEIGHT")]
    pub size: String,

    /// Frame rate asked of a side-by-side camera (Hz).
    #[arg(long, default_value_t = 30.0, value_name = "HZ")]
    pub fps: f64,

    /// Stop after this many frames (otherwise when the source ends, or on Ctrl-C).
    #[arg(long, value_name = "N")]
    pub frames: Option<u64>,

    /// Record the grids (`depth_grid`) and the stage timings (`stereo_timing`) to this MCAP file.
    #[arg(long, value_name = "FILE.mcap")]
    pub record: Option<PathBuf>,

    /// Print only the timing summary, not every frame's grid.
    #[arg(long)]
    pub quiet: bool,
}
