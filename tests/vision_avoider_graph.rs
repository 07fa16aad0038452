//! The avoider actor in a whole graph on the lockstep clock: a scripted camera publishes depth
//! grids at 15 Hz, a scripted commander cruises north at 4 m/s, and a log actor keeps every
//! `AvoidanceCommand`. The script: a clear view, an obstacle ahead and to the left, a wall
//! filling the view, the camera stalling, a clear view again.

#[path = "../actors/avoider/tests/scenes/mod.rs"]
mod scenes;

use std::path::Path;
use std::sync::Mutex;
use std::time::Duration;

use kestrel::{LoadedConfig, Registry, RunOptions, RunReport, run};
use kestrel_avoider::AvoiderActor;
use kestrel_proto::messages::{AvoidanceCommand, DepthGrid, Setpoint};
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup, Time};
use scenes::{at, blocked, clear_grid, flying_north, grid};

/// The camera's script: what it sees at `t` seconds, `None` while it is stalled.
fn scene(t: f64) -> Option<DepthGrid> {
    match t {
        t if t < 1.0 => Some(clear_grid(t, blocked(&[]))),
        t if t < 2.0 => Some(clear_grid(t, blocked(&[(1, 0), (1, 1)]))),
        t if t < 3.0 => Some(clear_grid(t, [[1.0; 3]; 3])),
        t if t < 4.0 => None,
        t => Some(grid(t, blocked(&[]), [[0.1; 3]; 3])),
    }
}

/// Publishes the scripted depth grids on `depth_grid` at 15 Hz.
struct Camera {
    out: Publisher<DepthGrid>,
}

impl Actor for Camera {
    type Params = toml::Table;
    type Input = Time;

    fn build(_: &toml::Table, setup: &mut impl Setup<Time>) -> Result<Camera, ActorError> {
        setup.timer("frame", Duration::from_micros(66_667), |t| t);
        Ok(Camera { out: setup.output("depth_grid") })
    }

    async fn handle(&mut self, _ctx: &Context, t: Time) -> Result<(), ActorError> {
        if let Some(grid) = scene(t.as_secs_f64()) {
            self.out.publish(grid);
        }
        Ok(())
    }
}

/// Publishes a setpoint cruising north at 4 m/s on `setpoint` at 10 Hz.
struct Cruise {
    out: Publisher<Setpoint>,
}

impl Actor for Cruise {
    type Params = toml::Table;
    type Input = Time;

    fn build(_: &toml::Table, setup: &mut impl Setup<Time>) -> Result<Cruise, ActorError> {
        setup.timer("tick", Duration::from_millis(100), |t| t);
        Ok(Cruise { out: setup.output("setpoint") })
    }

    async fn handle(&mut self, _ctx: &Context, t: Time) -> Result<(), ActorError> {
        self.out.publish(flying_north(t.as_secs_f64(), 4.0));
        Ok(())
    }
}

/// Every command the log actor received (one graph runs at a time: a single test function).
static COMMANDS: Mutex<Vec<AvoidanceCommand>> = Mutex::new(Vec::new());

/// Keeps every `AvoidanceCommand` in [`COMMANDS`].
struct CommandLog;

impl Actor for CommandLog {
    type Params = toml::Table;
    type Input = AvoidanceCommand;

    fn build(_: &toml::Table, setup: &mut impl Setup<AvoidanceCommand>) -> Result<CommandLog, ActorError> {
        setup.input("avoidance_command", |c| c);
        Ok(CommandLog)
    }

    async fn handle(&mut self, _ctx: &Context, command: AvoidanceCommand) -> Result<(), ActorError> {
        COMMANDS.lock().map_err(|e| ActorError::Failed(e.to_string()))?.push(command);
        Ok(())
    }
}

const GRAPH: &str = r#"
[actors.camera]
type = "camera"

[actors.commander]
type = "cruise"

[actors.avoider]
type = "avoider"
params = { filter_time_constant_s = 0.2, max_grid_age_s = 0.4 }
inputs.depth_grid = { topic = "depth_grid", mailbox = "latest" }
inputs.setpoint = { topic = "setpoint", mailbox = "latest" }

[actors.log]
type = "command_log"
inputs.avoidance_command = { topic = "avoidance_command", mailbox = "queue(16)" }
"#;

fn fly() -> (RunReport, Vec<AvoidanceCommand>) {
    COMMANDS.lock().expect("not poisoned").clear();
    let registry = Registry::new()
        .with::<Camera>("camera")
        .with::<Cruise>("cruise")
        .with::<AvoiderActor>("avoider")
        .with::<CommandLog>("command_log");
    let config = LoadedConfig::parse(Path::new("graph.toml"), GRAPH).expect("valid graph");
    let options =
        RunOptions { duration: Some(Duration::from_secs(5)), speedup: Some(0.0), ..RunOptions::default() };
    let report = run(&config, &registry, options).expect("runs");
    let commands = std::mem::take(&mut *COMMANDS.lock().expect("not poisoned"));
    (report, commands)
}

fn published(report: &RunReport, topic: &str) -> u64 {
    report.topics.iter().find(|(name, _, _)| name == topic).map_or(0, |t| t.2)
}

/// The commands made between `from` and `to` seconds.
fn between(commands: &[AvoidanceCommand], from: f64, to: f64) -> Vec<&AvoidanceCommand> {
    commands.iter().filter(|c| c.time >= at(from) && c.time < at(to)).collect()
}

#[test]
fn the_avoider_steers_climbs_and_reports_a_stalled_camera_in_a_lockstep_graph() {
    let (report, commands) = fly();
    assert!(report.supervisor_events.is_empty(), "{:?}", report.supervisor_events);
    let grids = published(&report, "depth_grid");
    // Frames at k·66.667 ms from k = 1: 44 before the stall at 3 s, 15 after it ends at 4 s.
    assert_eq!(grids, 59, "15 Hz for 4 of the 5 s");
    let stale = commands.iter().filter(|c| c.health.stale).count() as u64;
    assert_eq!(
        published(&report, "avoidance_command"),
        grids + stale,
        "one command per grid, plus stale ones"
    );
    assert_eq!(commands.len() as u64, grids + stale, "every command reached the log");

    for c in between(&commands, 0.1, 1.0) {
        assert!(c.velocity_frd_m_s.iter().all(|v| v.abs() < 5e-3), "clear view at {}: {c:?}", c.time);
        assert_eq!((c.desired_speed_m_s, c.speed_input), (4.0, 0.8));
    }
    // Three time constants (0.2 s) after the obstacle appeared the filter is 95% there.
    for c in between(&commands, 1.6, 2.0) {
        let [forward, right, down] = c.velocity_frd_m_s;
        assert!(
            forward < -3.8 && right > 3.8 && down.abs() < 0.01,
            "brake, steer right at {}: {c:?}",
            c.time
        );
        assert!(c.health.centre_blocked && c.rule_activations[11] > 0.6, "high-speed D_lc rule: {c:?}");
    }
    for c in between(&commands, 2.5, 3.0) {
        assert!(c.health.climbing && c.velocity_frd_m_s[2] < -1.4, "climb at {}: {c:?}", c.time);
    }
    // The last grid is captured at 2.933 s; it is stale after 0.4 s, at the 3.4 s check.
    let stalled = between(&commands, 3.0, 4.0);
    assert!(stalled.iter().all(|c| c.health.stale && c.time >= at(3.4)), "{stalled:?}");
    assert_eq!(stalled.len(), 6, "checks at 3.4 … 3.9 s");
    let last_stale = stalled.last().expect("stale commands");
    assert!(last_stale.velocity_frd_m_s[2] > -0.1, "the climb decays: {last_stale:?}");
    assert_eq!(last_stale.grid_time, Some(Time::from_micros(2_933_348)));
    // The stall braked to −4 m/s forward; the camera is back at 4.0 s and the brake releases
    // through the filter: e^(−3.5) of it is left after 0.7 s.
    for c in between(&commands, 4.05, 5.0) {
        assert!(!c.health.stale, "fresh again: {c:?}");
    }
    for c in between(&commands, 4.7, 5.0) {
        let [forward, right, down] = c.velocity_frd_m_s;
        assert!(forward.abs() < 0.15 && right.abs() < 0.01 && down.abs() < 0.01, "clear again: {c:?}");
    }

    let (_, again) = fly();
    assert_eq!(commands, again, "a lockstep run is deterministic");
}
