//! `log_replay`: publishes a recorded flight log's sensor topics into a live graph, each message
//! at its recorded log time on the graph clock, so the estimator (or anything downstream of the
//! sensors) runs on a real flight as it did then — "estimator + link on a recorded log". The
//! log is read by [`FlightLog`], as `kestrel replay` reads it: a Kestrel MCAP log or a PX4 ULog.
//!
//! ```toml
//! [actors.replay]
//! type = "log_replay"
//! params = { log = "../tests/data/sim-sensors.mcap", topics = ["imu", "gps", "baro", "mag"] }
//! ```
//!
//! * `log` — a Kestrel MCAP log or a PX4 ULog, relative to the config file.
//! * `topics` — the recorded topics to publish. In a Kestrel log each must hold one of the
//!   replayable types (`ImuSample`, `GpsFix`, `BaroSample`, `MagSample`, `BatteryStatus`, see
//!   [`crate::flight_log::replayable`]); in a ULog they are PX4's sensor topics
//!   (`sensor_combined`, `vehicle_gps_position` or `sensor_gps`, `vehicle_air_data`,
//!   `vehicle_magnetometer`), stamped with the log's `EKF2_*_DELAY` lags — give the estimator
//!   the same lags. Each goes out on its type's port (`imu`, `gps`, `baro`, `mag`, `battery`;
//!   rename the graph topic with `outputs.PORT`), so one topic per type.
//! * `speed` — log seconds per graph second (default 1). Under the lockstep clock a replay runs
//!   as fast as the graph handles it whatever the speed; under the real-time clock it keeps the
//!   recorded pace divided by `speed`.
//!
//! The run ends with the log, as Ctrl-C would: a bench replay is over when its log is.
//!
//! The log is read and checked while the graph is built, so a missing or corrupt file, a topic
//! the log lacks, or a topic of a type that cannot be replayed is a config error naming them.
//! The actor is a shell around [`Schedule`] and [`Pace`]: at start it spawns one task that
//! sleeps on the graph clock until each message is due and publishes it.

mod error;
mod outputs;
mod schedule;

use std::convert::Infallible;
use std::path::PathBuf;
use std::sync::Arc;

use kestrel_proto::{Actor, ActorError, Clock, Context, Setup};
use serde::Deserialize;
use tokio::task::JoinHandle;

pub use error::LogReplayError;
use outputs::Outputs;
pub use schedule::{Pace, Schedule};

use crate::flight_log::{FlightLog, Kind, Replayed};

/// `[actors.NAME.params]` of a `log_replay` actor.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LogReplayParams {
    /// The MCAP log, relative to the config file's directory.
    pub log: PathBuf,
    /// Recorded topics to publish.
    pub topics: Vec<String>,
    /// Log seconds per graph second.
    #[serde(default = "normal_speed")]
    pub speed: f64,
}

fn normal_speed() -> f64 {
    1.0
}

/// The `log_replay` actor.
pub struct LogReplayActor {
    /// Handed to the playing task at start.
    pending: Option<(Schedule<Replayed>, Outputs)>,
    speed: f64,
    task: Option<JoinHandle<()>>,
}

impl LogReplayActor {
    /// Reads the selected topics of the log into one schedule and declares their ports.
    fn open(
        params: &LogReplayParams,
        setup: &mut impl Setup<Infallible>,
    ) -> Result<LogReplayActor, LogReplayError> {
        let (slowest, fastest) = crate::config::SPEEDUP_RANGE;
        if !(slowest..=fastest).contains(&params.speed) {
            return Err(LogReplayError::Speed { speed: params.speed });
        }
        let path = setup.config_dir().join(&params.log);
        if params.topics.is_empty() {
            return Err(LogReplayError::NoTopics { path });
        }
        let log = FlightLog::open(&path)?;
        if let Some(damage) = log.damage() {
            tracing::warn!(log = %path.display(), "the log is damaged or cut short, replaying what was readable: {damage}");
        }
        let mut kinds: Vec<(Kind, &str)> = Vec::new();
        let mut entries = Vec::new();
        for (i, topic) in params.topics.iter().enumerate() {
            if params.topics[..i].contains(topic) {
                return Err(LogReplayError::DuplicateTopic { topic: topic.clone() });
            }
            let sensor = log.sensor(topic)?;
            if let Some((_, first)) = kinds.iter().find(|(k, _)| *k == sensor.kind) {
                return Err(LogReplayError::SameType {
                    path,
                    first: (*first).to_owned(),
                    second: topic.clone(),
                    type_name: sensor.kind.type_name(),
                    port: sensor.kind.port(),
                });
            }
            kinds.push((sensor.kind, topic));
            entries.extend(sensor.samples.iter().cloned());
        }
        let outputs = Outputs::declare(&kinds.iter().map(|(k, _)| *k).collect::<Vec<_>>(), setup);
        Ok(LogReplayActor {
            pending: Some((Schedule::new(entries), outputs)),
            speed: params.speed,
            task: None,
        })
    }
}

impl Actor for LogReplayActor {
    type Params = LogReplayParams;
    /// The replay has no inputs: its task publishes on its own.
    type Input = Infallible;

    fn build(params: &LogReplayParams, setup: &mut impl Setup<Infallible>) -> Result<Self, ActorError> {
        LogReplayActor::open(params, setup).map_err(|e| ActorError::Params(e.to_string()))
    }

    async fn start(&mut self, ctx: &Context) -> Result<(), ActorError> {
        let (schedule, outputs) =
            self.pending.take().ok_or_else(|| ActorError::Failed("log replay already started".into()))?;
        tracing::info!(actor = ctx.name(), messages = schedule.len(), "log replay starting");
        self.task = Some(tokio::spawn(play(schedule, outputs, self.speed, ctx.clone())));
        Ok(())
    }

    async fn handle(&mut self, _ctx: &Context, input: Infallible) -> Result<(), ActorError> {
        match input {}
    }

    async fn stop(&mut self, _ctx: &Context) {
        if let Some(task) = self.task.take() {
            task.abort();
        }
    }
}

/// Publishes each message when it is due on the graph clock, then ends the run.
async fn play(mut schedule: Schedule<Replayed>, outputs: Outputs, speed: f64, ctx: Context) {
    let clock: Arc<dyn Clock> = Arc::clone(ctx.clock());
    if let Some(first) = schedule.first_log_time() {
        let pace = Pace::new(first, ctx.now(), speed);
        while let Some((log_time, message)) = schedule.pop() {
            tokio::select! {
                _ = ctx.shutdown().cancelled() => return,
                _ = clock.sleep_until(pace.graph_time(log_time)) => {}
            }
            outputs.publish(message);
        }
    }
    tracing::info!(actor = ctx.name(), "log replay finished");
    ctx.end_run();
}
