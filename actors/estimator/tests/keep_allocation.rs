//! Keeping the filter for a restarted successor (`Keepsake::keep`, every `KEEP_PERIOD_US` of
//! IMU time on the estimator's path) copies into the kept filter's buffers: after the first
//! keep, none allocates. A counting global allocator watches keeps that alternate between two
//! filters flown differently (other buffer fillings, other states), and the kept copy must be
//! the filter it copied, field for field (its `Debug` text). One test function, so that no
//! other test thread allocates while it counts.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

#[allow(dead_code, reason = "the flight helpers are shared with sim_flight.rs, which uses the rest")]
mod common;

use common::{Faults, fly, params};
use kestrel_estimator::Ekf;
use kestrel_proto::Keepsake;

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);
static ALLOCATED_BYTES: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards to the system allocator unchanged; only counts calls and bytes.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        ALLOCATED_BYTES.fetch_add(layout.size(), Ordering::SeqCst);
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        ALLOCATED_BYTES.fetch_add(new_size, Ordering::SeqCst);
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Allocations and bytes allocated while `f` runs.
fn counted(f: impl FnOnce()) -> (usize, usize) {
    let (calls, bytes) = (ALLOCATIONS.load(Ordering::SeqCst), ALLOCATED_BYTES.load(Ordering::SeqCst));
    f();
    (ALLOCATIONS.load(Ordering::SeqCst) - calls, ALLOCATED_BYTES.load(Ordering::SeqCst) - bytes)
}

#[test]
fn keeping_the_filter_allocates_only_the_first_time_and_copies_it_whole() {
    let short = fly(params(), 8.0, Faults::default(), 1).ekf;
    let long = fly(params(), 12.0, Faults { gps_loss: Some((9.0, 10.0)), ..Faults::default() }, 2).ekf;
    assert!(short.is_sound() && long.is_sound(), "both filters are aligned and finite");
    let (short_text, long_text) = (format!("{short:?}"), format!("{long:?}"));
    assert_ne!(short_text, long_text, "two different filters");

    let keepsake = Keepsake::<Ekf>::new();
    let (first_calls, first_bytes) = counted(|| assert!(keepsake.keep(&short)));
    assert!(first_calls > 0, "the first keep makes the copy's buffers");
    let keeps = 100;
    let (calls, bytes) = counted(|| {
        for k in 0..keeps {
            assert!(keepsake.keep(if k % 2 == 0 { &long } else { &short }));
        }
    });
    println!(
        "figure: first keep {first_calls} allocations, {first_bytes} B (the buffers' capacity); \
         Ekf itself {} B; next {keeps} keeps {calls} allocations, {bytes} B",
        size_of::<Ekf>()
    );
    assert_eq!((calls, bytes), (0, 0), "keeps after the first allocate nothing");

    let kept = keepsake.take().expect("a filter was kept");
    assert_eq!(format!("{kept:?}"), short_text, "the last kept is the short flight's filter, whole");
    assert!(keepsake.keep(&long));
    let kept = keepsake.take().expect("a filter was kept");
    assert_eq!(format!("{kept:?}"), long_text, "a fresh copy (clone) is the filter, whole");
}
