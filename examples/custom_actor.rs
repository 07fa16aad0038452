//! An actor of your own in a Kestrel graph: `BoxWatch` follows the vehicle's estimated position
//! and publishes a `BoxExit` message, and logs a line, each time the vehicle leaves a box
//! around its origin. It flies with the stock flight actors on the simulator, in lockstep.
//!
//! Every actor has this shape (the contract is `kestrel_proto::Actor`):
//! * `Params`: its `[actors.NAME] params` table, read with serde (unknown keys refused);
//! * `build`: checks the params and declares ports — inputs by name, mapped into the actor's
//!   own `Input` type, and outputs, whose `Publisher`s it keeps;
//! * `handle`: one call per input message, in arrival order, on the actor's own task.
//!
//! The config decides which topic feeds each input and with what mailbox; the registry maps the
//! config's `type = "box_watch"` to this struct. A message type is plain data with a `time`
//! field, serde and a JSON Schema, so the recorder can log it like any of ours.
//!
//! ```sh
//! cargo run --example custom_actor                    # 20 simulated seconds of the square mission
//! cargo run --example custom_actor -- --seconds 60 --half-width-m 8 --ceiling-m 4
//! ```

use std::error::Error;
use std::path::Path;
use std::time::Duration;

use clap::Parser;
use kestrel::{LoadedConfig, Registry, RunOptions};
use kestrel_proto::messages::NavState;
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup, Time};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Published on `box_exit` when the vehicle leaves the box.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema)]
struct BoxExit {
    /// The navigation state's time (when it was measured).
    time: Time,
    /// Where the vehicle was: north, east, down from the estimator's origin (m).
    position_ned_m: [f64; 3],
    /// Which face it crossed: "north", "south", "east", "west" or "top".
    face: String,
}
kestrel_proto::impl_message!(BoxExit);

/// `params` of a `box_watch` actor: a box around the estimator's origin (the first GPS fix,
/// where the vehicle took off).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BoxWatchParams {
    /// Half the side of the box's square footprint (m).
    half_width_m: f64,
    /// Height of the box's top above the origin (m).
    ceiling_m: f64,
}

/// Watches the estimated position against the box.
struct BoxWatch {
    half_width_m: f64,
    ceiling_m: f64,
    /// Whether the last valid position was inside; `None` before the first.
    inside: Option<bool>,
    exits: Publisher<BoxExit>,
}

impl Actor for BoxWatch {
    type Params = BoxWatchParams;
    type Input = NavState;

    fn build(p: &BoxWatchParams, setup: &mut impl Setup<NavState>) -> Result<Self, ActorError> {
        // Bad parameters are an error at start-up, naming the field, never a silent default.
        if !(p.half_width_m.is_finite() && p.half_width_m > 0.0) {
            return Err(ActorError::Params(format!("half_width_m {} must be positive", p.half_width_m)));
        }
        if !(p.ceiling_m.is_finite() && p.ceiling_m > 0.0) {
            return Err(ActorError::Params(format!("ceiling_m {} must be positive", p.ceiling_m)));
        }
        setup.input("nav_state", |nav| nav);
        Ok(BoxWatch {
            half_width_m: p.half_width_m,
            ceiling_m: p.ceiling_m,
            inside: None,
            exits: setup.output("box_exit"),
        })
    }

    async fn handle(&mut self, ctx: &Context, nav: NavState) -> Result<(), ActorError> {
        // Only a position the estimator vouches for: before the first GPS fix, or after GPS
        // has been lost for its timeout, the position is not known.
        if !(nav.valid.horizontal_position && nav.valid.vertical_position) {
            return Ok(());
        }
        let [north, east, down] = nav.position_ned_m;
        let face = if -down > self.ceiling_m {
            Some("top")
        } else if north > self.half_width_m {
            Some("north")
        } else if north < -self.half_width_m {
            Some("south")
        } else if east > self.half_width_m {
            Some("east")
        } else if east < -self.half_width_m {
            Some("west")
        } else {
            None
        };
        let was_inside = self.inside.replace(face.is_none());
        match (was_inside, face) {
            (Some(true), Some(face)) => {
                println!(
                    "{}: left the box through the {face} at {:.2} s: N {north:+.1} m, E {east:+.1} m, height {:.1} m",
                    ctx.name(),
                    nav.time.as_secs_f64(),
                    -down
                );
                self.exits.publish(BoxExit {
                    time: nav.time,
                    position_ned_m: nav.position_ned_m,
                    face: face.into(),
                });
            }
            (Some(false), None) => {
                println!("{}: back in the box at {:.2} s", ctx.name(), nav.time.as_secs_f64())
            }
            _ => {}
        }
        Ok(())
    }
}

#[derive(Parser)]
#[command(about = "The simulator flying a mission, with a user-written actor watching a box")]
struct Args {
    /// Simulated seconds to run.
    #[arg(long, default_value_t = 20.0)]
    seconds: f64,
    /// Half the side of the box's footprint (m).
    #[arg(long, default_value_t = 5.0)]
    half_width_m: f64,
    /// Height of the box's top (m).
    #[arg(long, default_value_t = 15.0)]
    ceiling_m: f64,
}

fn main() -> Result<(), Box<dyn Error>> {
    let args = Args::parse();
    // The stock simulated vehicle (config/sim.toml), flying config/missions/square.plan on its
    // own (`auto`: arm and fly as soon as the pre-arm checks pass, as `kestrel run --auto`),
    // with one more actor. Its link listens on a free local port and sends nowhere, so the
    // example runs beside a `kestrel run` on the same machine; without the `[actors.link]`
    // table below, QGroundControl on this machine sees the flight as it sees `kestrel run`'s.
    let graph = format!(
        r#"
extends = "sim.toml"

[run]
speedup = 0.0        # lockstep as fast as the host allows
status_period_s = 0.0

[actors.commander]
params.mission = "missions/square.plan"
params.auto = true

[actors.link]
params.endpoints = [{{ type = "udp_in", bind = "127.0.0.1:0" }}]

[actors.box_watch]
type = "box_watch"
params = {{ half_width_m = {half_width_m:?}, ceiling_m = {ceiling_m:?} }}
# Only the newest state matters to a watcher: "latest" skips any it had no time for.
inputs.nav_state = {{ topic = "nav_state", mailbox = "latest" }}
"#,
        half_width_m = args.half_width_m,
        ceiling_m = args.ceiling_m
    );
    let at = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/custom_actor.toml");
    let config = LoadedConfig::parse(&at, &graph)?;
    // Every actor Kestrel ships, and ours under the name the config uses.
    let registry = Registry::standard().with::<BoxWatch>("box_watch");
    let duration =
        Duration::try_from_secs_f64(args.seconds).map_err(|e| format!("--seconds {}: {e}", args.seconds))?;
    let options = RunOptions { duration: Some(duration), ..RunOptions::default() };
    let report = kestrel::run(&config, &registry, options)?;

    let published = |topic: &str| report.topics.iter().find(|(t, _, _)| t == topic).map_or(0, |(_, _, n)| *n);
    println!(
        "stopped at {:.1} simulated s: {} nav_state messages, {} on box_exit",
        report.end_time.as_secs_f64(),
        published("nav_state"),
        published("box_exit")
    );
    Ok(())
}
