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

    /// Write the flight report (JSON: mission, collisions, estimator error against ground
    /// truth, control-loop timing, failsafes) to this file when the run ends.
    #[arg(long, value_name = "FILE.json")]
    pub report: Option<PathBuf>,

    /// Do not print the once-a-second status line.
    #[arg(long)]
    pub quiet: bool,
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
