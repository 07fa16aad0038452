//! The life of a byte-stream driver's reader task (GPS, SBUS): spawned at the actor's start,
//! checked on each health tick (a reader that has ended fails the actor, so the supervisor
//! restarts it), aborted at stop; and the per-second health report about it.

use std::future::Future;

use kestrel_proto::messages::SensorHealth;
use kestrel_proto::{ActorError, Context, Publisher, Time};
use tokio::task::JoinHandle;

use crate::health::{Counters, HealthWindow};

/// A reader task and its health reporting.
pub struct ReaderTask {
    /// Names the reader in errors ("GPS", "SBUS").
    what: &'static str,
    /// The device node, for health reports.
    device: String,
    task: Option<JoinHandle<Result<(), String>>>,
    /// Opened at start, on the running graph's clock.
    window: Option<HealthWindow>,
    health_out: Publisher<SensorHealth>,
}

impl ReaderTask {
    /// Not yet running; health reports go to `health_out`.
    pub fn new(what: &'static str, device: &str, health_out: Publisher<SensorHealth>) -> ReaderTask {
        ReaderTask { what, device: device.to_owned(), task: None, window: None, health_out }
    }

    /// Spawns `reader` and opens the health window at `ctx`'s time.
    pub fn start(
        &mut self,
        ctx: &Context,
        reader: impl Future<Output = Result<(), String>> + Send + 'static,
    ) {
        self.window = Some(HealthWindow::new(ctx.name(), &self.device, ctx.now()));
        self.task = Some(tokio::spawn(reader));
    }

    /// The health tick at `now`: an ended reader is the actor's failure; otherwise the report
    /// over `totals` is published.
    pub async fn tick(&mut self, now: Time, totals: Counters) -> Result<(), ActorError> {
        if let Some(task) = self.task.take_if(|t| t.is_finished()) {
            let reason = match task.await {
                Ok(Ok(())) => format!("the {} reader stopped", self.what),
                Ok(Err(e)) => e,
                Err(e) => format!("the {} reader failed: {e}", self.what),
            };
            return Err(ActorError::Failed(reason));
        }
        if let Some(window) = &mut self.window {
            self.health_out.publish(window.report(now, totals));
        }
        Ok(())
    }

    /// Aborts the reader.
    pub fn stop(&mut self) {
        if let Some(task) = self.task.take() {
            task.abort();
        }
    }
}
