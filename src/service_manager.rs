//! Talking to systemd (or any manager speaking its notify protocol) when it started the run:
//! `READY=1` once every actor is running, `WATCHDOG=1` at half the unit's `WatchdogSec` while
//! the graph is alive, `STOPPING=1` when a signal starts the shutdown, and `STATUS=` lines a
//! person sees in `systemctl status`. Outside a service (`NOTIFY_SOCKET` unset) each call does
//! nothing. The unit file is packaging/kestrel.service; tests/process_service_manager.rs reads what a
//! run sends on a socket of its own.
//!
//! The watchdog is fed only while the commander's status keeps arriving (when the graph has a
//! commander): a graph whose commander has stopped publishing is hung, and systemd's watchdog
//! action is the only thing left to act on it.

use std::sync::Arc;
use std::time::Duration;

use kestrel_proto::messages::VehicleStatus;
use sd_notify::NotifyState;
use tokio_util::sync::CancellationToken;

use crate::mailbox::Mailbox;

/// The notify socket, if a service manager gave one, and the watchdog period it asked for.
#[derive(Clone, Debug, Default)]
pub struct ServiceManager {
    enabled: bool,
    watchdog: Option<Duration>,
}

impl ServiceManager {
    /// From the environment systemd sets for a `Type=notify` unit (`NOTIFY_SOCKET`,
    /// `WATCHDOG_USEC`, `WATCHDOG_PID`).
    pub fn from_env() -> ServiceManager {
        ServiceManager {
            enabled: std::env::var_os("NOTIFY_SOCKET").is_some(),
            watchdog: sd_notify::watchdog_enabled().filter(|d| !d.is_zero()),
        }
    }

    /// The watchdog period systemd asked for (`WatchdogSec`).
    pub fn watchdog(&self) -> Option<Duration> {
        self.watchdog
    }

    fn send(&self, state: &[NotifyState]) {
        if !self.enabled {
            return;
        }
        if let Err(e) = sd_notify::notify(state) {
            tracing::warn!("cannot notify the service manager ({state:?}): {e}");
        }
    }

    /// Every actor is running.
    pub fn ready(&self, status: &str) {
        self.send(&[NotifyState::Ready, NotifyState::Status(status)]);
    }

    /// The run is ending (after a signal, once the vehicle is down).
    pub fn stopping(&self) {
        self.send(&[NotifyState::Stopping]);
    }

    /// One line for `systemctl status`.
    pub fn status(&self, status: &str) {
        self.send(&[NotifyState::Status(status)]);
    }

    /// Feeds the watchdog every half period while the graph lives (the commander's status,
    /// when there is one, arrived since the last feed), until `shutdown`.
    pub async fn feed_watchdog(
        self,
        alive: Option<Arc<Mailbox<VehicleStatus>>>,
        shutdown: CancellationToken,
    ) {
        let Some(period) = self.watchdog.filter(|_| self.enabled) else { return };
        let half = period / 2;
        let mut ticker = tokio::time::interval_at(tokio::time::Instant::now() + half, half);
        loop {
            tokio::select! {
                _ = shutdown.cancelled() => return,
                _ = ticker.tick() => {}
            }
            let fresh = match &alive {
                None => true,
                Some(status) => {
                    let mut any = false;
                    while status.take().is_some() {
                        any = true;
                    }
                    any
                }
            };
            if fresh {
                self.send(&[NotifyState::Watchdog]);
            } else {
                tracing::warn!("the commander's status has stopped: not feeding the watchdog");
            }
        }
    }
}
