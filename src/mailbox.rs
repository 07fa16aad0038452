//! Mailboxes: where a topic leaves messages for one subscribing actor.
//!
//! The kind is chosen per route in the config, never implicitly:
//! * `queue(n)` keeps every message, up to `n`; a message arriving at a full queue is refused
//!   and counted as an overflow (and logged), never dropped silently.
//! * `latest` keeps only the newest message; an unread one that is replaced is counted as
//!   conflated. Right for state that supersedes itself: navigation state, setpoints, frames.
//!
//! All mailboxes of one actor share a [`Doorbell`]: it wakes the actor and numbers arrivals,
//! so the actor handles its inputs in the order they were published, across ports.

use std::collections::VecDeque;
use std::fmt;
use std::str::FromStr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

use tokio::sync::Notify;

use crate::activity::{Activity, Busy};

/// The most messages a `queue(N)` may hold: 2²⁰, a thousand times the deepest queue a graph
/// needs (an IMU queue of 64, the flight report's 65 536), and small enough that a full queue of
/// the largest message stays within a laptop's memory.
pub const MAX_QUEUE_CAPACITY: usize = 1 << 20;

/// Slots a queue reserves up front; a deeper one grows (once, never shrinking) as it fills.
const PREALLOCATED: usize = 1024;

/// How a route buffers messages for its subscriber.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MailboxKind {
    /// Every message, at most this many waiting.
    Queue(usize),
    /// Only the newest message.
    Latest,
}

impl FromStr for MailboxKind {
    type Err = String;

    /// Parses `latest` or `queue(N)` with `1 ≤ N ≤ MAX_QUEUE_CAPACITY`.
    fn from_str(s: &str) -> Result<Self, String> {
        let s = s.trim();
        if s == "latest" {
            return Ok(MailboxKind::Latest);
        }
        let inner = s.strip_prefix("queue(").and_then(|r| r.strip_suffix(')'));
        let too_deep = || format!("mailbox '{s}': a queue holds at most {MAX_QUEUE_CAPACITY} messages");
        match inner.map(|n| n.trim().parse::<usize>()) {
            Some(Ok(n)) if (1..=MAX_QUEUE_CAPACITY).contains(&n) => Ok(MailboxKind::Queue(n)),
            Some(Ok(n)) if n > MAX_QUEUE_CAPACITY => Err(too_deep()),
            Some(Err(e)) if *e.kind() == std::num::IntErrorKind::PosOverflow => Err(too_deep()),
            _ => Err(format!("mailbox '{s}' is neither \"latest\" nor \"queue(N)\" with N ≥ 1")),
        }
    }
}

impl fmt::Display for MailboxKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MailboxKind::Queue(n) => write!(f, "queue({n})"),
            MailboxKind::Latest => f.write_str("latest"),
        }
    }
}

/// Wakes one actor when any of its mailboxes receives, and stamps arrival order.
#[derive(Debug, Default)]
pub struct Doorbell {
    ring: Notify,
    arrivals: AtomicU64,
}

impl Doorbell {
    /// A doorbell for a new actor.
    pub fn new() -> Arc<Doorbell> {
        Arc::new(Doorbell::default())
    }

    /// Completes after the next delivery (or at once if one happened since the last wait).
    pub async fn rung(&self) {
        self.ring.notified().await;
    }

    fn ring(&self) -> u64 {
        let n = self.arrivals.fetch_add(1, Ordering::Relaxed);
        self.ring.notify_one();
        n
    }
}

/// Counters a mailbox keeps for status lines and tests.
#[derive(Debug, Default)]
pub struct MailboxStats {
    /// Messages accepted.
    pub delivered: AtomicU64,
    /// Messages refused because a queue was full.
    pub overflowed: AtomicU64,
    /// Unread messages replaced by a newer one in a `latest` mailbox.
    pub conflated: AtomicU64,
}

/// Waiting messages, and whether their actor is down.
struct Letters<T> {
    queue: VecDeque<Letter<T>>,
    /// Set while the subscriber is between incarnations (failed, waiting for its restart, or
    /// given up): its waiting messages then count as no work, or the lockstep clock could never
    /// reach the restart.
    parked: bool,
}

struct Letter<T> {
    arrival: u64,
    message: T,
    busy: Option<Busy>,
}

/// A mailbox seen without its message type, for reports.
pub trait MailboxView: Send + Sync {
    /// `topic → actor.port`.
    fn label(&self) -> &str;
    /// The route's kind.
    fn kind(&self) -> MailboxKind;
    /// Delivery counters.
    fn stats(&self) -> &MailboxStats;
}

impl<T: Send> MailboxView for Mailbox<T> {
    fn label(&self) -> &str {
        &self.label
    }

    fn kind(&self) -> MailboxKind {
        self.kind
    }

    fn stats(&self) -> &MailboxStats {
        &self.stats
    }
}

/// One subscriber's buffer on one topic.
pub struct Mailbox<T> {
    /// `topic → actor.port`, for overflow reports.
    label: String,
    kind: MailboxKind,
    letters: Mutex<Letters<T>>,
    doorbell: Arc<Doorbell>,
    /// `None` for observers (status line, tests) whose unread messages must not hold the
    /// lockstep clock back.
    activity: Option<Arc<Activity>>,
    stats: MailboxStats,
}

impl<T> Mailbox<T> {
    /// A mailbox that counts its unread messages as graph work.
    pub fn new(
        label: String,
        kind: MailboxKind,
        doorbell: Arc<Doorbell>,
        activity: Arc<Activity>,
    ) -> Arc<Mailbox<T>> {
        Self::build(label, kind, doorbell, Some(activity))
    }

    /// A mailbox for an observer outside the graph: unread messages are not graph work.
    pub fn observer(label: String, kind: MailboxKind, doorbell: Arc<Doorbell>) -> Arc<Mailbox<T>> {
        Self::build(label, kind, doorbell, None)
    }

    fn build(
        label: String,
        kind: MailboxKind,
        doorbell: Arc<Doorbell>,
        activity: Option<Arc<Activity>>,
    ) -> Arc<Mailbox<T>> {
        let capacity = match kind {
            MailboxKind::Queue(n) => n.min(PREALLOCATED),
            MailboxKind::Latest => 1,
        };
        Arc::new(Mailbox {
            label,
            kind,
            letters: Mutex::new(Letters { queue: VecDeque::with_capacity(capacity), parked: false }),
            doorbell,
            activity,
            stats: MailboxStats::default(),
        })
    }

    /// Leaves `message` for the subscriber. Returns false if a full queue refused it.
    pub fn deliver(&self, message: T) -> bool {
        let mut guard = self.lock();
        let parked = guard.parked;
        let letters = &mut guard.queue;
        match self.kind {
            MailboxKind::Queue(capacity) if letters.len() >= capacity => {
                drop(guard);
                let n = self.stats.overflowed.fetch_add(1, Ordering::Relaxed) + 1;
                if n.is_power_of_two() {
                    tracing::warn!(route = %self.label, overflows = n, "mailbox full, message refused");
                }
                return false;
            }
            MailboxKind::Queue(_) => {}
            MailboxKind::Latest => {
                if letters.pop_front().is_some() {
                    self.stats.conflated.fetch_add(1, Ordering::Relaxed);
                }
            }
        }
        letters.push_back(Letter {
            arrival: self.doorbell.ring(),
            message,
            busy: self.activity.as_ref().filter(|_| !parked).map(|a| a.begin()),
        });
        self.stats.delivered.fetch_add(1, Ordering::Relaxed);
        true
    }

    /// Arrival number of the oldest waiting message.
    pub fn oldest_arrival(&self) -> Option<u64> {
        self.lock().queue.front().map(|l| l.arrival)
    }

    /// The subscriber went down: its waiting and future messages stop counting as work.
    pub fn park(&self) {
        let mut letters = self.lock();
        letters.parked = true;
        letters.queue.iter_mut().for_each(|l| l.busy = None);
    }

    /// The subscriber is back: its waiting messages count as work again.
    pub fn unpark(&self) {
        let mut letters = self.lock();
        letters.parked = false;
        if let Some(activity) = &self.activity {
            letters.queue.iter_mut().for_each(|l| l.busy = Some(activity.begin()));
        }
    }

    /// Takes the oldest waiting message, with the token that keeps it counted as unfinished
    /// work until the caller drops it.
    pub fn take(&self) -> Option<(T, Option<Busy>)> {
        self.lock().queue.pop_front().map(|l| (l.message, l.busy))
    }

    /// Messages waiting.
    pub fn len(&self) -> usize {
        self.lock().queue.len()
    }

    /// True when nothing is waiting.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn lock(&self) -> MutexGuard<'_, Letters<T>> {
        // A panic while holding this lock cannot leave the deque inconsistent (every
        // operation on it is a single push or pop), so a poisoned lock is safe to reuse.
        self.letters.lock().unwrap_or_else(|e| e.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mailbox(kind: MailboxKind) -> (Arc<Mailbox<u32>>, Arc<Activity>) {
        let activity = Activity::new();
        (Mailbox::new("t → a.p".into(), kind, Doorbell::new(), Arc::clone(&activity)), activity)
    }

    #[test]
    fn latest_keeps_only_the_newest_and_counts_the_rest() {
        let (mb, activity) = mailbox(MailboxKind::Latest);
        for i in 0..5 {
            assert!(mb.deliver(i));
        }
        assert_eq!(mb.len(), 1);
        assert_eq!(activity.outstanding(), 1, "replaced messages are no longer pending work");
        assert_eq!(mb.stats().conflated.load(Ordering::Relaxed), 4);
        let (v, busy) = mb.take().unwrap();
        assert_eq!(v, 4);
        drop(busy);
        assert!(activity.is_idle());
        assert!(mb.take().is_none());
    }

    #[test]
    fn full_queue_refuses_and_counts_overflow() {
        let (mb, activity) = mailbox(MailboxKind::Queue(3));
        let accepted: Vec<bool> = (0..5).map(|i| mb.deliver(i)).collect();
        assert_eq!(accepted, [true, true, true, false, false]);
        assert_eq!(mb.stats().overflowed.load(Ordering::Relaxed), 2);
        assert_eq!(activity.outstanding(), 3);
        let order: Vec<u32> = std::iter::from_fn(|| mb.take().map(|(v, _)| v)).collect();
        assert_eq!(order, [0, 1, 2], "a queue keeps every accepted message in order");
    }

    #[test]
    fn arrivals_are_numbered_across_mailboxes_of_one_actor() {
        let doorbell = Doorbell::new();
        let activity = Activity::new();
        let a =
            Mailbox::<u8>::new("a".into(), MailboxKind::Latest, Arc::clone(&doorbell), Arc::clone(&activity));
        let b = Mailbox::<u8>::new("b".into(), MailboxKind::Latest, Arc::clone(&doorbell), activity);
        b.deliver(1);
        a.deliver(2);
        assert!(b.oldest_arrival() < a.oldest_arrival());
    }

    #[test]
    fn a_parked_mailbox_holds_no_work_until_unparked() {
        let (mb, activity) = mailbox(MailboxKind::Queue(8));
        mb.deliver(1);
        mb.park();
        assert!(activity.is_idle(), "waiting messages of a downed actor are not work");
        mb.deliver(2);
        assert!(activity.is_idle());
        mb.unpark();
        assert_eq!(activity.outstanding(), 2, "both count again once the actor is back");
        let taken: Vec<u32> = std::iter::from_fn(|| mb.take().map(|(v, _)| v)).collect();
        assert_eq!(taken, [1, 2]);
        assert!(activity.is_idle());
    }

    #[test]
    fn mailbox_kind_parses_config_spelling() {
        assert_eq!("latest".parse(), Ok(MailboxKind::Latest));
        assert_eq!("queue(16)".parse(), Ok(MailboxKind::Queue(16)));
        assert!("queue(0)".parse::<MailboxKind>().is_err());
        assert!("fifo".parse::<MailboxKind>().is_err());
    }
}
