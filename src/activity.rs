//! Work in flight in the graph, so the lockstep clock knows when the graph has answered.
//!
//! Every message delivered to a mailbox, every timer that fires and every actor that is
//! (re)starting holds a [`Busy`] token until it has been handled. The lockstep driver
//! advances simulated time only when no token is outstanding: that is what "the simulator
//! advances only when the graph has answered its previous step" means in practice, and why a
//! simulated flight never depends on how fast the host machine is.

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use tokio::sync::Notify;

/// The graph-wide count of unfinished work.
#[derive(Debug, Default)]
pub struct Activity {
    outstanding: AtomicUsize,
    became_idle: Notify,
}

/// One unit of unfinished work; dropping it marks the work done.
#[derive(Debug)]
#[must_use = "the work counts as done when the token is dropped"]
pub struct Busy {
    activity: Arc<Activity>,
}

impl Activity {
    /// A new counter with nothing outstanding.
    pub fn new() -> Arc<Activity> {
        Arc::new(Activity::default())
    }

    /// Marks one unit of work as started.
    pub fn begin(self: &Arc<Self>) -> Busy {
        self.outstanding.fetch_add(1, Ordering::AcqRel);
        Busy { activity: Arc::clone(self) }
    }

    /// Units of work not yet finished.
    pub fn outstanding(&self) -> usize {
        self.outstanding.load(Ordering::Acquire)
    }

    /// True when no work is outstanding.
    pub fn is_idle(&self) -> bool {
        self.outstanding() == 0
    }

    /// Completes when no work is outstanding.
    pub async fn idle(&self) {
        loop {
            let notified = self.became_idle.notified();
            tokio::pin!(notified);
            notified.as_mut().enable();
            if self.is_idle() {
                return;
            }
            notified.await;
        }
    }
}

impl Drop for Busy {
    fn drop(&mut self) {
        if self.activity.outstanding.fetch_sub(1, Ordering::AcqRel) == 1 {
            self.activity.became_idle.notify_waiters();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn idle_waits_for_the_last_token() {
        let activity = Activity::new();
        let a = activity.begin();
        let b = activity.begin();
        assert_eq!(activity.outstanding(), 2);
        let waiter = tokio::spawn({
            let activity = Arc::clone(&activity);
            async move { activity.idle().await }
        });
        drop(a);
        tokio::task::yield_now().await;
        assert!(!waiter.is_finished());
        drop(b);
        waiter.await.unwrap();
        assert!(activity.is_idle());
    }
}
