//! A fixed-capacity ring buffer of time-stamped samples, oldest first: the IMU samples waiting
//! for the delayed fusion horizon, the observations waiting for it, and the output predictor's
//! past states (PX4 EKF2's `RingBuffer`).
//!
//! Capacity is fixed at construction, so steady-state operation never allocates; pushing into a
//! full buffer drops the oldest entry and counts it.

use std::collections::VecDeque;

/// A ring buffer holding at most `capacity` entries.
#[derive(Clone, Debug)]
pub struct DelayBuffer<T> {
    items: VecDeque<T>,
    capacity: usize,
    /// Entries dropped because the buffer was full, for the status message.
    overflows: u64,
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
}
