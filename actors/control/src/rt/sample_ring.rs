//! A wait-free single-producer, single-consumer ring of `Copy` values with a fixed capacity:
//! the real-time loop pushes one timing sample per iteration and a tokio task drains them, so
//! the histogram work (and its 400 kB of bins) stays off the real-time thread. A push never
//! waits or allocates; when the ring is full the sample is dropped and counted, never blocked on.
//!
//! Indices grow without wrapping (u64); the slot is `index % capacity`. The producer owns
//! `head`, the consumer owns `tail`; Release on each store publishes the slot contents (or the
//! freed slot) to the other side, Acquire on the other side's load takes them.

use std::cell::UnsafeCell;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

struct Shared<T> {
    slots: Box<[UnsafeCell<T>]>,
    /// Next index the producer writes.
    head: AtomicU64,
    /// Next index the consumer reads.
    tail: AtomicU64,
    /// Pushes refused because the ring was full.
    dropped: AtomicU64,
}

// SAFETY: a slot is written only by the producer while it lies in `tail + capacity > i >= head`
// (not visible to the consumer), and read only by the consumer while `tail <= i < head` (not
// writable by the producer); the indices move only through Release stores read with Acquire.
// `T: Send` because values cross threads.
unsafe impl<T: Send> Sync for Shared<T> {}

/// The pushing half (the real-time thread).
pub struct RingWriter<T> {
    shared: Arc<Shared<T>>,
}

/// The draining half.
pub struct RingReader<T> {
    shared: Arc<Shared<T>>,
}

/// A ring of `capacity` slots (at least 1), each starting as `fill`. The slots are written once
/// here, so their pages are touched before the real-time loop starts.
pub fn sample_ring<T: Copy + Send>(capacity: usize, fill: T) -> (RingWriter<T>, RingReader<T>) {
    let slots = (0..capacity.max(1)).map(|_| UnsafeCell::new(fill)).collect();
    let shared = Arc::new(Shared {
        slots,
        head: AtomicU64::new(0),
        tail: AtomicU64::new(0),
        dropped: AtomicU64::new(0),
    });
    (RingWriter { shared: Arc::clone(&shared) }, RingReader { shared })
}

impl<T> Shared<T> {
    fn slot(&self, index: u64) -> &UnsafeCell<T> {
        // The remainder is below the slot count, which fits a usize.
        &self.slots[(index % self.slots.len() as u64) as usize]
    }
}

impl<T: Copy + Send> RingWriter<T> {
    /// Appends `value`; false (and counted) when the ring is full.
    pub fn push(&mut self, value: T) -> bool {
        let head = self.shared.head.load(Ordering::Relaxed);
        let tail = self.shared.tail.load(Ordering::Acquire);
        if head - tail >= self.shared.slots.len() as u64 {
            self.shared.dropped.fetch_add(1, Ordering::Relaxed);
            return false;
        }
        // SAFETY: `head` is not yet visible to the consumer and the check above shows the slot
        // was already read, so the producer alone owns it.
        unsafe { *self.shared.slot(head).get() = value };
        self.shared.head.store(head + 1, Ordering::Release);
        true
    }
}

impl<T: Copy + Send> RingReader<T> {
    /// Hands every value pushed so far, oldest first, to `each`.
    pub fn drain(&mut self, mut each: impl FnMut(T)) {
        let head = self.shared.head.load(Ordering::Acquire);
        let mut tail = self.shared.tail.load(Ordering::Relaxed);
        while tail < head {
            // SAFETY: `tail < head`: the producer published this slot and will not write it
            // until `tail` moves past it.
            each(unsafe { *self.shared.slot(tail).get() });
            tail += 1;
            self.shared.tail.store(tail, Ordering::Release);
        }
    }

    /// Pushes refused so far because the ring was full.
    pub fn dropped(&self) -> u64 {
        self.shared.dropped.load(Ordering::Relaxed)
    }

    /// Whether the pushing half has been dropped.
    pub fn writer_gone(&self) -> bool {
        Arc::strong_count(&self.shared) == 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_full_ring_drops_and_counts_instead_of_overwriting() {
        let (mut w, mut r) = sample_ring(3, 0u32);
        assert!(w.push(1) && w.push(2) && w.push(3));
        assert!(!w.push(4), "full");
        assert_eq!(r.dropped(), 1);
        let mut got = Vec::new();
        r.drain(|v| got.push(v));
        assert_eq!(got, [1, 2, 3]);
        assert!(w.push(5) && w.push(6));
        r.drain(|v| got.push(v));
        assert_eq!(got, [1, 2, 3, 5, 6], "wraps around in order");
        drop(w);
        assert!(r.writer_gone());
    }

    #[test]
    fn concurrent_values_arrive_once_each_in_order_or_are_counted_as_dropped() {
        const N: u64 = 200_000;
        let (mut w, mut r) = sample_ring(64, [0u64; 4]);
        let writer = std::thread::spawn(move || {
            for i in 1..=N {
                w.push([i; 4]);
            }
        });
        let (mut received, mut last) = (0u64, 0u64);
        loop {
            let done = r.writer_gone();
            r.drain(|v| {
                assert!(v.iter().all(|x| *x == v[0]), "torn value {v:?}");
                assert!(v[0] > last, "out of order: {} after {last}", v[0]);
                last = v[0];
                received += 1;
            });
            if done {
                break;
            }
        }
        writer.join().expect("writer thread");
        r.drain(|_| received += 1);
        assert_eq!(received + r.dropped(), N, "every push is either received or counted");
    }
}
