//! `Engine::infer` allocates nothing: the avoider runs it on every depth frame, beside the
//! real-time controller. A counting global allocator watches one inference per rule base.

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use kestrel_avoider::{rule_file, thesis_engine};

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards to the system allocator unchanged; only counts calls.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn inference_does_not_allocate() {
    let every_shape = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/every_shape.fll");
    let engines = [thesis_engine().expect("loads"), rule_file::load(&every_shape).expect("loads")];
    for engine in &engines {
        let mut workspace = engine.workspace();
        let inputs: Vec<Vec<f64>> = (0..50)
            .map(|k| {
                engine
                    .inputs()
                    .iter()
                    .enumerate()
                    .map(|(j, v)| {
                        let t = ((k * 7 + j * 3) % 11) as f64 / 10.0;
                        v.min + t * (v.max - v.min)
                    })
                    .collect()
            })
            .collect();
        let before = ALLOCATIONS.load(Ordering::SeqCst);
        for x in &inputs {
            engine.infer(&mut workspace, x).expect("valid inputs");
        }
        let after = ALLOCATIONS.load(Ordering::SeqCst);
        assert_eq!(after - before, 0, "{}: inference allocated", engine.name());
    }
}
