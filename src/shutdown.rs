//! What a signal does to a running graph: never stop the motors of a vehicle in the air.
//!
//! SIGTERM (`systemctl stop`, a shutdown script), SIGINT (Ctrl-C) and SIGHUP (a dropped SSH
//! session) all mean "stop". With the vehicle disarmed, or with no commander in the graph, the
//! run ends at once. Armed, the runtime sends the commander `Command::Shutdown`, which lands a
//! flying vehicle (STATUSTEXT "shutdown requested: landing") or disarms one on the ground, and
//! the run ends once the commander reports it disarmed: the PWM outputs keep their flying pulses
//! all the way down. Only SIGKILL stops the process in the air.
//!
//! A further signal while landing is ignored on a realtime graph (real or emulated hardware) and
//! logged; in a lockstep simulation, where no motor is real, it ends the run at once.
//! Held by tests/hil_shutdown.rs (each signal, on the Navio2 graph) and tests/cli.rs.

use std::sync::Arc;

use kestrel_proto::messages::{Command, VehicleCommand, VehicleStatus};
use kestrel_proto::{Clock, Publisher};
use tokio_util::sync::CancellationToken;

use crate::mailbox::{Doorbell, Mailbox};
use crate::service_manager::ServiceManager;

/// Which signal arrived, for the log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Signal {
    Terminate,
    Interrupt,
    Hangup,
}

/// What the shutdown path needs of the graph: the commander's status and its command topic,
/// when the graph has a commander.
pub struct Vehicle {
    pub status: Arc<Mailbox<VehicleStatus>>,
    pub doorbell: Arc<Doorbell>,
    pub command: Publisher<VehicleCommand>,
}

/// Completes with the next SIGTERM, SIGINT or SIGHUP (never, where none can be listened for).
pub struct Signals {
    #[cfg(unix)]
    streams: Option<[(Signal, tokio::signal::unix::Signal); 3]>,
}

impl Signals {
    /// Installs the handlers; from now on these signals no longer kill the process.
    pub fn install() -> Signals {
        #[cfg(unix)]
        {
            use tokio::signal::unix::{SignalKind, signal};
            let streams = (|| {
                Ok::<_, std::io::Error>([
                    (Signal::Terminate, signal(SignalKind::terminate())?),
                    (Signal::Interrupt, signal(SignalKind::interrupt())?),
                    (Signal::Hangup, signal(SignalKind::hangup())?),
                ])
            })();
            if let Err(e) = &streams {
                tracing::error!("cannot listen for SIGTERM, SIGINT and SIGHUP: {e}");
            }
            Signals { streams: streams.ok() }
        }
        #[cfg(not(unix))]
        Signals {}
    }

    /// The next signal.
    pub async fn next(&mut self) -> Signal {
        #[cfg(unix)]
        if let Some([(a, sa), (b, sb), (c, sc)]) = self.streams.as_mut() {
            return tokio::select! {
                _ = sa.recv() => *a,
                _ = sb.recv() => *b,
                _ = sc.recv() => *c,
            };
        }
        std::future::pending().await
    }
}

/// Completes on the first SIGTERM, SIGINT or SIGHUP, for commands that fly nothing.
pub async fn interrupt() {
    Signals::install().next().await;
}

/// Ends the run (`shutdown`) on a signal, landing or disarming the vehicle first; returns when
/// `shutdown` is cancelled, by this or by the run's own end.
pub async fn on_signals(
    mut signals: Signals,
    vehicle: Option<Vehicle>,
    clock: Arc<dyn Clock>,
    simulated: bool,
    service: ServiceManager,
    shutdown: CancellationToken,
) {
    let first = tokio::select! {
        _ = shutdown.cancelled() => return,
        s = signals.next() => s,
    };
    service.stopping();
    let Some(vehicle) = vehicle else {
        tracing::info!(signal = ?first, "signal received, shutting down");
        shutdown.cancel();
        return;
    };
    let mut latest = vehicle.status.take().map(|(s, _)| s);
    if !latest.as_ref().is_some_and(|s| s.armed) {
        tracing::info!(signal = ?first, "signal received, disarmed: shutting down");
        shutdown.cancel();
        return;
    }
    tracing::warn!(signal = ?first, "signal received while armed: landing before shutting down");
    service.status("shutdown requested: landing");
    vehicle.command.publish(VehicleCommand { id: 0, time: clock.now(), command: Command::Shutdown });
    loop {
        if let Some(status) = latest.take_if(|s| !s.armed) {
            tracing::info!(
                t_s = status.time.as_secs_f64(),
                "disarmed after the shutdown request: shutting down"
            );
            shutdown.cancel();
            return;
        }
        tokio::select! {
            _ = shutdown.cancelled() => return,
            _ = vehicle.doorbell.rung() => {
                while let Some((s, _)) = vehicle.status.take() {
                    latest = Some(s);
                }
            }
            s = signals.next() => {
                if simulated {
                    tracing::warn!(signal = ?s, "second signal: a simulated vehicle stops where it is");
                    shutdown.cancel();
                    return;
                }
                tracing::warn!(
                    signal = ?s,
                    "still landing: the process ends once the vehicle is disarmed (SIGKILL stops the motors in the air)"
                );
            }
        }
    }
}
