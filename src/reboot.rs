//! MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN: once the commander has taken a reboot (disarmed, or
//! forced on the ground and disarmed: `Commander::on_command`), the run ends and `kestrel run`
//! exits with [`REBOOT_EXIT_CODE`]. The shipped systemd unit (packaging/kestrel.service) starts
//! it again on that code (`RestartForceExitStatus=`), so a restart is a fresh process: parameters
//! and missions reloaded from the state directory, drivers reopened, boot clock from zero, as
//! ArduPilot's `AP_Vehicle::reboot` resets its board. Run by hand or under a test, the process
//! just exits with that code; nothing restarts it in-process.
//!
//! The exit waits [`ACK_GRACE`] after the commander's answer so the link's COMMAND_ACK
//! ACCEPTED leaves the socket first. Held by tests/gcs_reboot_motor_test.rs.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use kestrel_proto::messages::{Command, CommandResult};
use tokio_util::sync::CancellationToken;

use crate::mailbox::{Doorbell, Mailbox};

/// The exit status of a run ended by a reboot: EX_TEMPFAIL of sysexits.h ("try again"), which
/// no other path of `kestrel` returns (errors exit 1).
pub const REBOOT_EXIT_CODE: u8 = 75;

/// Wall time between the accepted reboot and the end of the run: the link sends the ACK on
/// the commander's answer within one graph step, well inside this.
pub const ACK_GRACE: Duration = Duration::from_millis(300);

/// What the reboot watcher needs: the commander's answers (a queue, so no answer is missed).
pub struct RebootWatch {
    pub results: Arc<Mailbox<CommandResult>>,
    pub doorbell: Arc<Doorbell>,
}

/// Ends the run (`shutdown`) after an accepted reboot, setting `requested`; returns when
/// `shutdown` is cancelled, by this or by the run's own end.
pub async fn on_reboot(watch: RebootWatch, requested: Arc<AtomicBool>, shutdown: CancellationToken) {
    loop {
        while let Some((result, _)) = watch.results.take() {
            if matches!(result.command, Command::Reboot { .. }) && result.refusal.is_none() {
                tracing::warn!(
                    t_s = result.time.as_secs_f64(),
                    "reboot accepted: the run ends for a restart"
                );
                tokio::select! {
                    _ = shutdown.cancelled() => return,
                    _ = tokio::time::sleep(ACK_GRACE) => {}
                }
                requested.store(true, Ordering::SeqCst);
                shutdown.cancel();
                return;
            }
        }
        tokio::select! {
            _ = shutdown.cancelled() => return,
            _ = watch.doorbell.rung() => {}
        }
    }
}
