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

    /// Do not print the once-a-second status line.
    #[arg(long)]
    pub quiet: bool,
}
