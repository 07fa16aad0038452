//! Embedding the runtime: run the simulator with an actor of your own.
//!
//! `GpsWatch` subscribes to the simulator's GPS fixes and prints each one as metres from
//! home — the shape every Kestrel actor has: declare ports in `build`, react in `handle`.
//!
//! ```sh
//! cargo run --example gps_watch
//! ```

use std::path::Path;
use std::time::Duration;

use kestrel::{LoadedConfig, Registry, RunOptions};
use kestrel_proto::geo::{Geodetic, LocalFrame};
use kestrel_proto::messages::GpsFix;
use kestrel_proto::{Actor, ActorError, Context, Setup};
use serde::Deserialize;

/// Prints GPS fixes in local coordinates.
struct GpsWatch {
    home: LocalFrame,
}

/// `params` of a `gps_watch` actor.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct GpsWatchParams {
    home_lat_deg: f64,
    home_lon_deg: f64,
    home_alt_m: f64,
}

impl Actor for GpsWatch {
    type Params = GpsWatchParams;
    type Input = GpsFix;

    fn build(p: &GpsWatchParams, setup: &mut impl Setup<GpsFix>) -> Result<Self, ActorError> {
        setup.input("gps", |fix| fix);
        let home = Geodetic { lat_deg: p.home_lat_deg, lon_deg: p.home_lon_deg, alt_m: p.home_alt_m };
        Ok(GpsWatch { home: LocalFrame::new(home) })
    }

    async fn handle(&mut self, ctx: &Context, fix: GpsFix) -> Result<(), ActorError> {
        let [n, e, d] =
            self.home.to_ned(Geodetic { lat_deg: fix.lat_deg, lon_deg: fix.lon_deg, alt_m: fix.alt_msl_m });
        println!(
            "{}: fix measured at {} (arrived {:.0} ms later): N {n:+.2} m, E {e:+.2} m, D {d:+.2} m, {} satellites",
            ctx.name(),
            fix.time,
            ctx.now().saturating_since(fix.time).as_secs_f64() * 1e3,
            fix.satellites
        );
        Ok(())
    }
}

const GRAPH: &str = r#"
[run]
speedup = 0.0

[actors.sim]
type = "sim"
params = { vehicle = "vehicles/quad_x.toml", world = "worlds/empty.toml" }

[actors.watch]
type = "gps_watch"
params = { home_lat_deg = 6.79710, home_lon_deg = 79.90170, home_alt_m = 20.0 }
inputs.gps = { topic = "gps", mailbox = "queue(8)" }
"#;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // Relative paths in the graph resolve against config/, as if this text were a file there.
    let at = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/gps_watch.toml");
    let config = LoadedConfig::parse(&at, GRAPH)?;
    let registry = Registry::standard().with::<GpsWatch>("gps_watch");
    let options = RunOptions { duration: Some(Duration::from_secs(2)), ..Default::default() };
    let report = kestrel::run(&config, &registry, options)?;
    println!("stopped at {}", report.end_time);
    Ok(())
}
