//! `kestrel report`: plots (PNG) and a summary of errors from a recorded flight.

use std::path::PathBuf;

use kestrel::flight_plots::write_report;

/// Arguments of `kestrel report`.
#[derive(Debug, clap::Args)]
pub struct ReportArgs {
    /// The flight log (MCAP, as written by `kestrel run --record`).
    pub log: PathBuf,
    /// Directory for the PNG plots and summary.json (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

/// Writes the report of `args.log` into `args.out` and prints its summary.
pub fn run(args: ReportArgs) -> Result<(), String> {
    let summary = write_report(&args.log, &args.out).map_err(|e| e.to_string())?;
    println!("{summary}");
    Ok(())
}
