//! The one-line status a person watching `kestrel run` sees every second: graph time, how
//! fast it runs against the wall clock, what the vehicle is doing, and message rates.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use kestrel_proto::messages::{GroundTruth, VehicleStatus};
use kestrel_proto::{Clock, Time};
use tokio_util::sync::CancellationToken;

use crate::graph::TopicHandle;
use crate::mailbox::Mailbox;
use crate::recorder::OnboardStatus;
use crate::serde_name::serde_name;

/// Topics whose rates the status line shows, in this order, when they exist.
const SHOWN: &[&str] = &["imu", "gps", "baro", "mag", "ground_truth", "actuator_outputs", "nav_state"];

/// Prints the status line every `period` of wall time until `shutdown`.
pub async fn run(
    period: Duration,
    clock: Arc<dyn Clock>,
    topics: Vec<TopicHandle>,
    truth: Option<Arc<Mailbox<GroundTruth>>>,
    commander: Option<Arc<Mailbox<VehicleStatus>>>,
    onboard_log: Option<Arc<Mutex<OnboardStatus>>>,
    shutdown: CancellationToken,
) {
    let shown: Vec<&TopicHandle> =
        SHOWN.iter().filter_map(|name| topics.iter().find(|t| t.name == *name)).collect();
    let mut counts: Vec<u64> = shown.iter().map(|t| t.published()).collect();
    let mut last_sim = clock.now();
    let mut last_wall = tokio::time::Instant::now();
    let mut latest_truth: Option<GroundTruth> = None;
    let mut latest_status: Option<VehicleStatus> = None;
    let mut ticker = tokio::time::interval_at(last_wall + period, period);
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => return,
            _ = ticker.tick() => {}
        }
        let now = clock.now();
        let sim_dt = now.saturating_since(last_sim).as_secs_f64();
        let wall_dt = last_wall.elapsed().as_secs_f64();
        if let Some(t) = truth.as_ref().and_then(|m| m.take()) {
            latest_truth = Some(t.0);
        }
        if let Some(s) = commander.as_ref().and_then(|m| m.take()) {
            latest_status = Some(s.0);
        }
        let rates: Vec<String> = shown
            .iter()
            .zip(counts.iter_mut())
            .map(|(topic, count)| {
                let n = topic.published();
                let rate = if sim_dt > 0.0 { (n - *count) as f64 / sim_dt } else { 0.0 };
                *count = n;
                format!("{} {rate:.0}/s", topic.name)
            })
            .collect();
        tracing::info!(
            target: "kestrel::status",
            "t={} (x{:.1}) {}{} | {}{}",
            seconds(now),
            if wall_dt > 0.0 { sim_dt / wall_dt } else { 0.0 },
            mode(latest_status.as_ref()),
            vehicle(latest_truth.as_ref()),
            rates.join(" "),
            log_state(onboard_log.as_deref())
        );
        last_sim = now;
        last_wall = tokio::time::Instant::now();
    }
}

/// ` | log 00000003.mcap`, and the last log error, ` | LOG ERROR: …`.
fn log_state(onboard: Option<&Mutex<OnboardStatus>>) -> String {
    let Some(status) = onboard else { return String::new() };
    let s = status.lock().unwrap_or_else(|e| e.into_inner());
    let mut text = String::new();
    if let Some(name) = s.current.as_ref().and_then(|p| p.file_name()) {
        text += &format!(" | log {}", name.to_string_lossy());
    }
    if let Some(error) = &s.last_error {
        text += &format!(" | LOG ERROR: {error}");
    }
    text
}

fn seconds(t: Time) -> String {
    format!("{:.1}s", t.as_secs_f64())
}

/// `AUTO armed, mission 3/6, failsafe rtl (battery_low); ` from the commander's status.
fn mode(status: Option<&VehicleStatus>) -> String {
    let Some(s) = status else { return String::new() };
    let mut text =
        format!("{} {}", serde_name(&s.mode).to_uppercase(), if s.armed { "armed" } else { "disarmed" });
    if s.mission.total > 0 {
        text += &format!(", mission {}/{}", s.mission.reached, s.mission.total);
    }
    if let Some(f) = s.failsafe {
        text += &format!(", failsafe {} ({})", serde_name(&f.action), serde_name(&f.cause));
    }
    text + "; "
}

fn vehicle(truth: Option<&GroundTruth>) -> String {
    let Some(t) = truth else {
        return "vehicle: no ground truth".to_owned();
    };
    let state = if t.crashed {
        "crashed"
    } else if t.landed {
        "landed"
    } else {
        "flying"
    };
    let [n, e, d] = t.position_ned_m;
    format!("vehicle {state} at N {n:.1} E {e:.1} alt {:.1} m, collisions {}", 0.0 - d, t.collisions)
}
