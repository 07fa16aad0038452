//! Topics: a named stream of one message type, fanned out to its subscribers' mailboxes and,
//! when selected, to the flight-log recorder.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

use kestrel_proto::{Clock, Message, Sink};

use crate::mailbox::Mailbox;
use crate::recorder::RecordChannel;

/// One topic of message type `T`.
///
/// Subscribers and the recorder are attached while the graph is wired, then frozen: publishing
/// reads them without taking a lock.
pub struct Topic<T: Message> {
    name: String,
    clock: Arc<dyn Clock>,
    wiring: Mutex<Vec<Arc<Mailbox<T>>>>,
    subscribers: OnceLock<Box<[Arc<Mailbox<T>>]>>,
    recorder: OnceLock<RecordChannel<T>>,
    published: AtomicU64,
}

impl<T: Message> Topic<T> {
    /// An unwired topic.
    pub fn new(name: &str, clock: Arc<dyn Clock>) -> Arc<Topic<T>> {
        Arc::new(Topic {
            name: name.to_owned(),
            clock,
            wiring: Mutex::new(Vec::new()),
            subscribers: OnceLock::new(),
            recorder: OnceLock::new(),
            published: AtomicU64::new(0),
        })
    }

    /// The topic's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Adds a subscriber; only before [`Topic::freeze`].
    pub fn subscribe(&self, mailbox: Arc<Mailbox<T>>) {
        self.wiring.lock().unwrap_or_else(|e| e.into_inner()).push(mailbox);
    }

    /// Sends every message to the recorder too.
    pub fn record_to(&self, channel: RecordChannel<T>) {
        // Set once while wiring; a second call keeps the first channel.
        let _ = self.recorder.set(channel);
    }

    /// Ends wiring: the subscriber list is fixed from here on.
    pub fn freeze(&self) {
        let subscribers = std::mem::take(&mut *self.wiring.lock().unwrap_or_else(|e| e.into_inner()));
        let _ = self.subscribers.set(subscribers.into_boxed_slice());
    }

    /// Messages published so far.
    pub fn published(&self) -> u64 {
        self.published.load(Ordering::Relaxed)
    }
}

impl<T: Message> Sink<T> for Topic<T> {
    fn publish(&self, msg: T) {
        self.published.fetch_add(1, Ordering::Relaxed);
        if let Some(recorder) = self.recorder.get() {
            recorder.record(self.clock.now(), &msg);
        }
        let Some((last, rest)) = self.subscribers.get().and_then(|s| s.split_last()) else {
            return;
        };
        for mailbox in rest {
            mailbox.deliver(msg.clone());
        }
        last.deliver(msg);
    }
}
