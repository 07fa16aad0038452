//! The `kestrel` command.

mod cli;
mod cmd;

use std::io::IsTerminal;
use std::process::ExitCode;

use clap::Parser;
use tracing_subscriber::EnvFilter;

use cli::{Cli, Command};

fn main() -> ExitCode {
    let cli = Cli::parse();
    let filter = EnvFilter::try_from_default_env()
        .or_else(|_| EnvFilter::try_new(&cli.log_level))
        .unwrap_or_else(|e| {
            eprintln!("warning: --log-level '{}' is not a valid filter ({e}); using info", cli.log_level);
            EnvFilter::new("info")
        });
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .init();
    std::panic::set_hook(Box::new(|info| tracing::error!(target: "kestrel::panic", "{info}")));

    let result = match cli.command {
        Command::Run(args) => cmd::run::run(args).map(|ended| match ended {
            cmd::run::Ended::Done => ExitCode::SUCCESS,
            cmd::run::Ended::Reboot => ExitCode::from(kestrel::reboot::REBOOT_EXIT_CODE),
        }),
        Command::Fuzzy(args) => cmd::fuzzy::run(args).map(|()| ExitCode::SUCCESS),
        Command::Replay(args) => cmd::replay::run(args).map(|()| ExitCode::SUCCESS),
        Command::Calibrate(args) => cmd::calibrate::run(args).map(|()| ExitCode::SUCCESS),
        Command::Disparity(args) => cmd::disparity::run(args).map(|()| ExitCode::SUCCESS),
        Command::Stereo(args) => cmd::stereo::run(args).map(|()| ExitCode::SUCCESS),
        Command::Report(args) => cmd::report::run(args).map(|()| ExitCode::SUCCESS),
        Command::Sitl(args) => cmd::sitl::run(args).map(|()| ExitCode::SUCCESS),
    };
    match result {
        Ok(code) => code,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}
