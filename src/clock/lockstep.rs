//! Lockstep simulation time, as PX4's SITL does it: time stands still while the graph works,
//! and jumps to the next deadline once every actor has answered.
//!
//! Any sleep on this clock registers a deadline. The [`LockstepDriver`] waits until the graph
//! holds no unfinished work (see [`crate::activity`]), then advances `now` to the earliest
//! deadline and wakes its sleepers, each of which carries a [`Busy`] token until it resumes.
//! A run is therefore deterministic (on a single-threaded runtime) and as fast as the host
//! allows, or paced to a chosen multiple of real time.

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::future::Future;
use std::pin::Pin;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::task::{Context, Poll, Waker};
use std::time::Duration;

use kestrel_proto::clock::Sleep;
use kestrel_proto::{Clock, Time};
use tokio_util::sync::CancellationToken;

use crate::activity::{Activity, Busy};

/// Simulation time that advances only when the graph is idle.
#[derive(Clone)]
pub struct LockstepClock {
    inner: Arc<Inner>,
}

struct Inner {
    now_us: AtomicU64,
    activity: Arc<Activity>,
    sleepers: Mutex<Sleepers>,
}

#[derive(Default)]
struct Sleepers {
    /// Deadlines by (time, registration order), so equal deadlines wake in a fixed order.
    queue: BinaryHeap<Reverse<(Time, u64)>>,
    slots: std::collections::HashMap<u64, Arc<Slot>>,
    next_id: u64,
}

#[derive(Default)]
struct Slot {
    state: Mutex<SlotState>,
}

#[derive(Default)]
struct SlotState {
    waker: Option<Waker>,
    /// Held from the moment the driver wakes the sleeper until it resumes.
    woken: Option<Busy>,
}

impl Slot {
    fn lock(&self) -> MutexGuard<'_, SlotState> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }
}

impl LockstepClock {
    /// A clock at time zero that counts its wake-ups as work in `activity`.
    pub fn new(activity: Arc<Activity>) -> LockstepClock {
        LockstepClock {
            inner: Arc::new(Inner {
                now_us: AtomicU64::new(0),
                activity,
                sleepers: Mutex::new(Sleepers::default()),
            }),
        }
    }

    /// The earliest deadline anyone is sleeping until.
    pub fn next_deadline(&self) -> Option<Time> {
        let mut sleepers = self.inner.lock_sleepers();
        while let Some(&Reverse((t, id))) = sleepers.queue.peek() {
            if sleepers.slots.contains_key(&id) {
                return Some(t);
            }
            sleepers.queue.pop();
        }
        None
    }

    /// Sets now to `t` and wakes every sleeper whose deadline has come, in deadline order.
    pub fn advance_to(&self, t: Time) {
        let previous = self.inner.now_us.fetch_max(t.as_micros(), Ordering::AcqRel);
        debug_assert!(previous <= t.as_micros(), "lockstep time never goes back");
        let mut sleepers = self.inner.lock_sleepers();
        while let Some(&Reverse((deadline, id))) = sleepers.queue.peek() {
            if deadline > t {
                break;
            }
            sleepers.queue.pop();
            if let Some(slot) = sleepers.slots.remove(&id) {
                let mut state = slot.lock();
                state.woken = Some(self.inner.activity.begin());
                if let Some(waker) = state.waker.take() {
                    waker.wake();
                }
            }
        }
    }
}

impl Inner {
    fn lock_sleepers(&self) -> MutexGuard<'_, Sleepers> {
        self.sleepers.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn now(&self) -> Time {
        Time::from_micros(self.now_us.load(Ordering::Acquire))
    }
}

impl Clock for LockstepClock {
    fn now(&self) -> Time {
        self.inner.now()
    }

    fn sleep_until(&self, deadline: Time) -> Sleep {
        Box::pin(LockstepSleep { inner: Arc::clone(&self.inner), deadline, registered: None })
    }
}

struct LockstepSleep {
    inner: Arc<Inner>,
    deadline: Time,
    registered: Option<(u64, Arc<Slot>)>,
}

impl Future for LockstepSleep {
    type Output = ();

    fn poll(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<()> {
        if self.inner.now() >= self.deadline {
            // Release the wake-up token: from here the sleeper's own work holds the graph.
            if let Some((_, slot)) = self.registered.take() {
                slot.lock().woken = None;
            }
            return Poll::Ready(());
        }
        match &self.registered {
            Some((_, slot)) => slot.lock().waker = Some(cx.waker().clone()),
            None => {
                let slot = Arc::new(Slot::default());
                slot.lock().waker = Some(cx.waker().clone());
                let mut sleepers = self.inner.lock_sleepers();
                let id = sleepers.next_id;
                sleepers.next_id += 1;
                sleepers.queue.push(Reverse((self.deadline, id)));
                sleepers.slots.insert(id, Arc::clone(&slot));
                drop(sleepers);
                self.registered = Some((id, slot));
            }
        }
        Poll::Pending
    }
}

impl Drop for LockstepSleep {
    fn drop(&mut self) {
        if let Some((id, slot)) = self.registered.take() {
            self.inner.lock_sleepers().slots.remove(&id);
            slot.lock().woken = None;
        }
    }
}

/// Advances a [`LockstepClock`] whenever the graph is idle, optionally paced to real time.
pub struct LockstepDriver {
    clock: LockstepClock,
    activity: Arc<Activity>,
    /// Simulated seconds per wall-clock second; `None` runs as fast as the host allows.
    speedup: Option<f64>,
    /// Simulated time at which the run ends.
    end: Option<Time>,
}

impl LockstepDriver {
    /// A driver for `clock`.
    pub fn new(
        clock: LockstepClock,
        activity: Arc<Activity>,
        speedup: Option<f64>,
        end: Option<Time>,
    ) -> Self {
        LockstepDriver { clock, activity, speedup, end }
    }

    /// Runs until `end` (then cancels `shutdown`) or until `shutdown` is cancelled.
    pub async fn run(self, shutdown: CancellationToken) {
        let wall_origin = tokio::time::Instant::now();
        let sim_origin = self.clock.now();
        loop {
            tokio::select! {
                _ = shutdown.cancelled() => return,
                _ = self.activity.idle() => {}
            }
            // Let tasks that are already runnable go first; only a graph that stays idle
            // past them has answered.
            tokio::task::yield_now().await;
            if !self.activity.is_idle() {
                continue;
            }
            let Some(next) = self.clock.next_deadline() else {
                // Nothing scheduled: only outside input (a socket) can wake the graph.
                tokio::select! {
                    _ = shutdown.cancelled() => return,
                    _ = tokio::time::sleep(Duration::from_millis(10)) => continue,
                }
            };
            if self.end.is_some_and(|end| next > end) {
                self.clock.advance_to(self.end.unwrap_or(next));
                shutdown.cancel();
                return;
            }
            if let Some(speedup) = self.speedup {
                let sim_elapsed = next.saturating_since(sim_origin).as_secs_f64();
                let due = wall_origin + Duration::from_secs_f64(sim_elapsed / speedup);
                tokio::select! {
                    _ = shutdown.cancelled() => return,
                    _ = tokio::time::sleep_until(due) => {}
                }
            }
            self.clock.advance_to(next);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test(flavor = "current_thread")]
    async fn sleepers_wake_in_deadline_order_and_hold_the_graph_until_they_resume() {
        let activity = Activity::new();
        let clock = LockstepClock::new(Arc::clone(&activity));
        let order = Arc::new(Mutex::new(Vec::new()));
        for (name, at) in [("b", 20), ("a", 10), ("c", 30)] {
            let clock2 = clock.clone();
            let order = Arc::clone(&order);
            tokio::spawn(async move {
                clock2.sleep_until(Time::from_micros(at)).await;
                order.lock().unwrap().push((name, clock2.now().as_micros()));
            });
        }
        tokio::task::yield_now().await;
        assert_eq!(clock.next_deadline(), Some(Time::from_micros(10)));
        let shutdown = CancellationToken::new();
        LockstepDriver::new(clock.clone(), Arc::clone(&activity), None, Some(Time::from_micros(25)))
            .run(shutdown.clone())
            .await;
        assert!(shutdown.is_cancelled());
        assert_eq!(*order.lock().unwrap(), [("a", 10), ("b", 20)]);
        assert_eq!(clock.now(), Time::from_micros(25));
        assert!(activity.is_idle());
    }

    #[tokio::test(flavor = "current_thread")]
    async fn a_dropped_sleep_does_not_hold_the_clock() {
        let activity = Activity::new();
        let clock = LockstepClock::new(Arc::clone(&activity));
        let mut sleep = clock.sleep_until(Time::from_micros(5));
        assert!(futures_poll_once(&mut sleep).is_pending());
        drop(sleep);
        assert_eq!(clock.next_deadline(), None);
        clock.advance_to(Time::from_micros(10));
        assert!(activity.is_idle());
    }

    fn futures_poll_once(f: &mut Sleep) -> Poll<()> {
        let waker = Waker::noop();
        f.as_mut().poll(&mut Context::from_waker(waker))
    }
}
