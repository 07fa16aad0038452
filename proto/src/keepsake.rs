//! What an actor keeps across its restarts.
//!
//! Supervision restarts a failed actor from its parameters (Erlang's one-for-one): whatever it
//! had learnt is gone. For most actors that is right — the state may be what made it fail. For
//! the estimator in flight it is not: a cold estimator must align again on a *still* vehicle,
//! so a restart in the air would leave the vehicle without a state for good. A [`Keepsake`] is
//! the one door through which an incarnation hands its successor a copy of its state; the
//! successor decides whether the copy is sound enough to resume from (the estimator checks it
//! is finite and aligned, else it starts cold).

use std::sync::{Arc, Mutex, TryLockError};

/// A slot for one value that outlives the incarnation that filled it. Clones share the slot.
pub struct Keepsake<T> {
    slot: Arc<Mutex<Option<T>>>,
}

impl<T> Clone for Keepsake<T> {
    fn clone(&self) -> Self {
        Keepsake { slot: Arc::clone(&self.slot) }
    }
}

impl<T> Default for Keepsake<T> {
    fn default() -> Self {
        Keepsake { slot: Arc::new(Mutex::new(None)) }
    }
}

impl<T: Clone> Keepsake<T> {
    /// An empty slot.
    pub fn new() -> Self {
        Self::default()
    }

    /// Keeps a copy of `value` in place of the previous one, reusing its allocations
    /// (`clone_from`), so keeping at a steady rate does not allocate. Never waits: when the slot
    /// is busy (only a successor taking it can make it so) nothing is kept and `false` returned.
    pub fn keep(&self, value: &T) -> bool {
        let mut slot = match self.slot.try_lock() {
            Ok(slot) => slot,
            Err(TryLockError::WouldBlock) => return false,
            // A keeper that panicked mid-copy left a value that may be half written: drop it.
            Err(TryLockError::Poisoned(poisoned)) => {
                let mut slot = poisoned.into_inner();
                *slot = None;
                self.slot.clear_poison();
                slot
            }
        };
        match slot.as_mut() {
            Some(kept) => kept.clone_from(value),
            None => *slot = Some(value.clone()),
        }
        true
    }

    /// Takes the kept value out, leaving the slot empty; `None` when nothing was kept (or the
    /// keeper died while copying).
    pub fn take(&self) -> Option<T> {
        match self.slot.lock() {
            Ok(mut slot) => slot.take(),
            Err(poisoned) => {
                poisoned.into_inner().take();
                self.slot.clear_poison();
                None
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_kept_value_is_taken_once_by_any_clone() {
        let keepsake = Keepsake::<Vec<u32>>::new();
        assert_eq!(keepsake.take(), None);
        assert!(keepsake.keep(&vec![1, 2, 3]));
        assert!(keepsake.keep(&vec![4, 5]));
        let successor = keepsake.clone();
        assert_eq!(successor.take(), Some(vec![4, 5]));
        assert_eq!(keepsake.take(), None);
    }

    #[test]
    fn keeping_while_the_slot_is_busy_skips_instead_of_waiting() {
        let keepsake = Keepsake::<u32>::new();
        let guard = keepsake.slot.lock().unwrap();
        assert!(!keepsake.keep(&7));
        drop(guard);
        assert!(keepsake.keep(&7));
        assert_eq!(keepsake.take(), Some(7));
    }

    #[test]
    fn a_keeper_that_panicked_mid_copy_leaves_nothing() {
        #[derive(Debug)]
        struct Bomb;
        impl Clone for Bomb {
            fn clone(&self) -> Self {
                Bomb
            }
            fn clone_from(&mut self, _: &Self) {
                panic!("mid-copy");
            }
        }
        let keepsake = Keepsake::<Bomb>::new();
        assert!(keepsake.keep(&Bomb));
        let other = keepsake.clone();
        assert!(std::panic::catch_unwind(move || other.keep(&Bomb)).is_err());
        assert!(keepsake.take().is_none());
        assert!(keepsake.keep(&Bomb));
        assert!(keepsake.take().is_some());
    }
}
