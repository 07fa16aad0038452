//! A wait-free single-producer, single-consumer triple buffer: the writer always has a slot to
//! write, the reader always sees the newest complete value, and neither ever waits or
//! allocates after construction. This is how the real-time loop takes the newest NavState and
//! setpoint from the actor's mailbox without locks.
//!
//! Three slots: the writer owns one (`back`), the reader owns one (`front`), and the third is
//! exchanged through one atomic byte holding its index plus a "fresh" bit. Publishing swaps
//! the writer's slot into the middle; reading swaps the middle into the reader's slot when it
//! is fresh. Release/acquire on the swaps orders the slot contents with the exchange.

use std::cell::UnsafeCell;
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

const INDEX: u8 = 0b011;
const FRESH: u8 = 0b100;

struct Shared<T> {
    slots: [UnsafeCell<T>; 3],
    middle: AtomicU8,
}

// SAFETY: each slot is accessed by at most one side at a time: the writer only touches the
// slot it owns (`back`), the reader only the one it owns (`front`), and ownership changes hands
// only through the atomic swap of `middle`, whose AcqRel ordering publishes the slot's
// contents to the other side. `T: Send` is required because values cross threads.
unsafe impl<T: Send> Sync for Shared<T> {}

/// The writing half.
pub struct Writer<T> {
    shared: Arc<Shared<T>>,
    back: u8,
}

/// The reading half.
pub struct Reader<T> {
    shared: Arc<Shared<T>>,
    front: u8,
}

/// A triple buffer whose three slots start as clones of `initial`.
pub fn triple_buffer<T: Clone + Send>(initial: T) -> (Writer<T>, Reader<T>) {
    let shared = Arc::new(Shared {
        slots: [UnsafeCell::new(initial.clone()), UnsafeCell::new(initial.clone()), UnsafeCell::new(initial)],
        middle: AtomicU8::new(1),
    });
    (Writer { shared: Arc::clone(&shared), back: 0 }, Reader { shared, front: 2 })
}

impl<T: Send> Writer<T> {
    /// Publishes `value`; the reader sees it (or a newer one) on its next read.
    pub fn write(&mut self, value: T) {
        // SAFETY: `back` is owned by the writer alone until the swap below hands it over.
        unsafe { *self.shared.slots[usize::from(self.back)].get() = value };
        let previous = self.shared.middle.swap(self.back | FRESH, Ordering::AcqRel);
        self.back = previous & INDEX;
    }

    /// Whether the reading half has been dropped.
    pub fn reader_gone(&self) -> bool {
        Arc::strong_count(&self.shared) == 1
    }
}

impl<T: Send> Reader<T> {
    /// The newest value, and whether it is new since the previous read.
    pub fn read(&mut self) -> (&T, bool) {
        let fresh = self.shared.middle.load(Ordering::Relaxed) & FRESH != 0;
        if fresh {
            let previous = self.shared.middle.swap(self.front, Ordering::AcqRel);
            self.front = previous & INDEX;
        }
        // SAFETY: `front` is owned by the reader alone until it is swapped back.
        (unsafe { &*self.shared.slots[usize::from(self.front)].get() }, fresh)
    }

    /// Whether a value newer than the last read is waiting (a peek: nothing is taken).
    pub fn has_fresh(&self) -> bool {
        self.shared.middle.load(Ordering::Acquire) & FRESH != 0
    }

    /// Whether the writing half has been dropped.
    pub fn writer_gone(&self) -> bool {
        Arc::strong_count(&self.shared) == 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reader_sees_the_newest_value_once_as_fresh() {
        let (mut w, mut r) = triple_buffer(0u32);
        assert_eq!(r.read(), (&0, false));
        w.write(1);
        w.write(2);
        assert!(r.has_fresh() && r.has_fresh(), "a peek takes nothing");
        assert_eq!(r.read(), (&2, true));
        assert!(!r.has_fresh());
        assert_eq!(r.read(), (&2, false));
        w.write(3);
        assert_eq!(r.read(), (&3, true));
        drop(w);
        assert!(r.writer_gone());
    }

    #[test]
    fn concurrent_reads_are_never_torn_and_never_go_back() {
        const N: u64 = 200_000;
        let (mut w, mut r) = triple_buffer([0u64; 16]);
        let writer = std::thread::spawn(move || {
            for i in 1..=N {
                w.write([i; 16]);
            }
        });
        let mut last = 0;
        while last < N {
            let (v, _) = r.read();
            assert!(v.iter().all(|x| *x == v[0]), "torn read {v:?}");
            assert!(v[0] >= last, "went back from {last} to {}", v[0]);
            last = v[0];
        }
        writer.join().expect("writer thread");
    }
}
