//! A recorder write error is reported at once, not when the run ends: a full disk or a
//! read-only card loses the flight log from the first failed write, and the pilot should know
//! while the vehicle flies. Every [`POLL`] the watch asks the writer
//! ([`WriteFailureProbe`]); from the first failure on it logs the error once and publishes a
//! `sensor_health` report each second (sensor `recorder`, the file and the error as the device,
//! one error), which the link sends as a STATUSTEXT warning as it does for a failing driver: at
//! once, then every 30 s while disarmed (`actors/link/src/services/sensor_health.rs`).
//! `tests/log_recorder.rs` holds it: `kestrel run --record /dev/full` reports within a second.

use std::sync::Arc;
use std::time::Duration;

use kestrel_proto::messages::SensorHealth;
use kestrel_proto::{Clock, Publisher};
use tokio_util::sync::CancellationToken;

use super::WriteFailureProbe;

/// How often the writer is asked (wall clock): a tenth of the one second allowed.
pub const POLL: Duration = Duration::from_millis(100);
/// Reports after the first come this often (wall clock), as a driver's health does.
const REPORT_EVERY: u32 = 10;

/// Watches `probe` until `shutdown`, publishing on `health`.
pub async fn run(
    probe: WriteFailureProbe,
    clock: Arc<dyn Clock>,
    health: Publisher<SensorHealth>,
    shutdown: CancellationToken,
) {
    let mut ticker = tokio::time::interval(POLL);
    let mut reports: u64 = 0;
    let mut ticks_since_report: u32 = 0;
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => return,
            _ = ticker.tick() => {}
        }
        let Some(failure) = probe.failure() else { continue };
        if reports > 0 && ticks_since_report + 1 < REPORT_EVERY {
            ticks_since_report += 1;
            continue;
        }
        if reports == 0 {
            tracing::error!("flight log write failed, recording stopped: {failure}");
        }
        reports += 1;
        ticks_since_report = 0;
        health.publish(SensorHealth {
            time: clock.now(),
            sensor: "recorder".into(),
            device: format!("flight log write failed: {failure}"),
            rate_hz: 0.0,
            errors: 1,
            errors_total: reports,
            clipped: 0,
        });
    }
}
