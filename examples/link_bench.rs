//! The MAVLink link alone, for a ground station to connect to: no vehicle, no simulator.
//!
//! `config/bench-link.toml` is a graph of one actor, the link, on the wall clock. With no
//! commander behind it the link answers for the vehicle itself: it sends system 1's heartbeat
//! and serves the parameters the bench config lists, so a ground station, a radio or a network
//! can be checked on a desk. This example loads that graph as a user's own config would,
//! through `extends`, replaces the link's endpoints with the command line's, and runs it with
//! `kestrel::run` for `--seconds` (or until Ctrl-C).
//!
//! ```sh
//! cargo run --example link_bench -- --seconds 60        # QGroundControl or MAVProxy on 14550
//! mavproxy.py --master udpin:127.0.0.1:14550            # in another terminal
//! cargo run --example link_bench -- --gcs 192.168.1.20:14550 --listen 0.0.0.0:14540
//! ```

use std::error::Error;
use std::net::SocketAddr;
use std::path::Path;

use clap::Parser;
use kestrel::{LoadedConfig, Registry, RunOptions};
use tracing_subscriber::EnvFilter;

#[derive(Parser)]
#[command(about = "A link-only Kestrel graph a ground station can connect to")]
struct Args {
    /// Where the link sends MAVLink, as a ground station listens (QGroundControl, MAVProxy: 14550).
    #[arg(long, default_value = "127.0.0.1:14550")]
    gcs: SocketAddr,
    /// Where the link answers whoever sends to it (scripts, MAVSDK-style clients).
    #[arg(long, default_value = "0.0.0.0:14540")]
    listen: SocketAddr,
    /// End on its own after this many seconds (default: run until Ctrl-C).
    #[arg(long)]
    seconds: Option<f64>,
}

fn main() -> Result<(), Box<dyn Error>> {
    let args = Args::parse();
    // The runtime logs through `tracing`: what the link does, and a status line every second.
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("info"));
    tracing_subscriber::fmt().with_env_filter(filter).with_writer(std::io::stderr).init();

    // A graph of our own on top of the bench config: `extends` merges key by key and replaces
    // other values, so this list of endpoints replaces the one in bench-link.toml while the
    // link's parameters and the clock stay as that file says.
    let graph = format!(
        r#"
extends = "bench-link.toml"

[actors.link]
params.endpoints = [
    {{ type = "udp_out", address = "{gcs}" }},
    {{ type = "udp_in", bind = "{listen}", max_peers = 8 }},
]
"#,
        gcs = args.gcs,
        listen = args.listen
    );
    // Relative paths (the `extends` above) resolve against config/, as if this text were a file there.
    let at = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/link_bench.toml");
    let config = LoadedConfig::parse(&at, &graph)?;

    let duration = args
        .seconds
        .map(kestrel::config::check_duration_s)
        .transpose()
        .map_err(|e| format!("--seconds {e}"))?;
    println!(
        "link only: MAVLink to {} and answering on {}; {}",
        args.gcs,
        args.listen,
        duration.map_or("Ctrl-C to stop".to_owned(), |d| format!("stopping after {} s", d.as_secs_f64()))
    );
    let options = RunOptions { duration, status: true, ..RunOptions::default() };
    let report = kestrel::run(&config, &Registry::standard(), options)?;

    // What the graph did: the messages on each topic, and any actor that failed.
    println!("stopped at {:.1} s", report.end_time.as_secs_f64());
    for (topic, type_name, count) in &report.topics {
        println!("  {topic:<20} {type_name:<28} {count} messages");
    }
    for event in &report.supervisor_events {
        println!("  supervisor: {event:?}");
    }
    Ok(())
}
