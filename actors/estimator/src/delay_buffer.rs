//! A fixed-capacity ring buffer of time-stamped samples, oldest first: the IMU samples waiting
//! for the delayed fusion horizon, the observations waiting for it, and the output predictor's
//! past states (PX4 EKF2's `RingBuffer`).
//!
//! Capacity is fixed at construction, so steady-state operation never allocates; pushing into a
//! full buffer drops the oldest entry and counts it. A copy has the same capacity, and copying
//! into one (`clone_from`, the estimator's keepsake) reuses its storage.

use std::collections::VecDeque;

/// A ring buffer holding at most `capacity` entries.
#[derive(Debug)]
pub struct DelayBuffer<T> {
    items: VecDeque<T>,
    capacity: usize,
    /// Entries dropped because the buffer was full, for the status message.
    overflows: u64,
}

impl<T: Clone> Clone for DelayBuffer<T> {
    fn clone(&self) -> Self {
        let mut copy = DelayBuffer::new(self.capacity);
        copy.clone_from(self);
        copy
    }

    /// Copies `source` into this buffer's storage: no allocation when it already holds
    /// `source`'s capacity (the derived `clone_from` would build a new buffer and drop this one).
    fn clone_from(&mut self, source: &Self) {
        let DelayBuffer { items, capacity, overflows } = source;
        self.items.clear();
        self.items.reserve(*capacity);
        self.items.extend(items.iter().cloned());
        self.capacity = *capacity;
        self.overflows = *overflows;
    }
}

impl<T> DelayBuffer<T> {
    /// An empty buffer for `capacity` entries (at least one).
    pub fn new(capacity: usize) -> DelayBuffer<T> {
        let capacity = capacity.max(1);
        DelayBuffer { items: VecDeque::with_capacity(capacity), capacity, overflows: 0 }
    }

    /// Appends `item` as the newest entry, dropping the oldest when full.
    pub fn push(&mut self, item: T) {
        if self.items.len() == self.capacity {
            self.items.pop_front();
            self.overflows += 1;
        }
        self.items.push_back(item);
    }

    /// The oldest entry.
    pub fn oldest(&self) -> Option<&T> {
        self.items.front()
    }

    /// The newest entry.
    pub fn newest(&self) -> Option<&T> {
        self.items.back()
    }

    /// Removes and returns the oldest entry.
    pub fn pop_oldest(&mut self) -> Option<T> {
        self.items.pop_front()
    }

    /// Removes and returns the oldest entry if `pred` holds for it.
    pub fn pop_oldest_if(&mut self, pred: impl FnOnce(&T) -> bool) -> Option<T> {
        if self.items.front().is_some_and(pred) { self.items.pop_front() } else { None }
    }

    /// Every entry, oldest first, for in-place correction.
    pub fn iter_mut(&mut self) -> impl Iterator<Item = &mut T> {
        self.items.iter_mut()
    }

    pub fn len(&self) -> usize {
        self.items.len()
    }

    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// Entries dropped because the buffer was full.
    pub fn overflows(&self) -> u64 {
        self.overflows
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_the_newest_and_counts_what_it_drops() {
        let mut b = DelayBuffer::new(3);
        for i in 0..5 {
            b.push(i);
        }
        assert_eq!((b.len(), b.overflows()), (3, 2));
        assert_eq!(b.pop_oldest_if(|&x| x > 2), None);
        assert_eq!(b.pop_oldest_if(|&x| x == 2), Some(2));
        assert_eq!((b.oldest(), b.newest()), (Some(&3), Some(&4)));
    }

    #[test]
    fn a_copy_into_another_buffer_holds_the_same_entries_and_capacity() {
        let mut source = DelayBuffer::new(4);
        for i in 0..7 {
            source.push(i);
        }
        let mut copy = DelayBuffer::new(4);
        copy.push(99);
        copy.clone_from(&source);
        let entries = |b: &DelayBuffer<i32>| b.items.iter().copied().collect::<Vec<_>>();
        assert_eq!((entries(&copy), copy.overflows()), (vec![3, 4, 5, 6], 3));
        // Full at the same capacity: the next push drops the oldest, as in the source.
        copy.push(7);
        source.push(7);
        assert_eq!((entries(&copy), copy.overflows()), (entries(&source), source.overflows()));
        let fresh = source.clone();
        assert_eq!((entries(&fresh), fresh.capacity, fresh.overflows()), (entries(&source), 4, 4));
    }
}
