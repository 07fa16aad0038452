//! `Engine::infer` and the avoider's update allocate nothing: the avoider runs on every depth
//! frame, beside the real-time controller. A counting global allocator watches inferences of
//! each rule base and a run of avoider updates with poses and a filling obstacle memory. One
//! test function, so that no other test thread allocates while it counts.

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

mod memory_scenes;
mod scenes;

use kestrel_avoider::{Avoider, AvoiderParams, rule_file, thesis_engine};
use memory_scenes::{nav_at, with_sectors};
use scenes::{at, blocked, clear_grid, flying_north, grid};

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
fn inference_and_avoider_updates_do_not_allocate() {
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

    let mut avoider = Avoider::thesis(AvoiderParams::default()).expect("builds");
    avoider.set_setpoint(&flying_north(0.0, 3.0)).expect("valid setpoint");
    let mut textureless = [[0.0; 3]; 3];
    textureless[1][1] = 0.9;
    let scenes = [blocked(&[]), blocked(&[(1, 1), (0, 2)]), [[1.0; 3]; 3], blocked(&[(1, 1)])];
    let grids: Vec<_> = (0..40)
        .map(|k| {
            let t = f64::from(k) * 0.05;
            let g = match k % 5 {
                4 => grid(t, [[0.0; 3]; 3], textureless),
                n => clear_grid(t, scenes[n as usize]),
            };
            // Trunks in view that the obstacle memory takes in and then carries out of view.
            with_sectors(g, &[(k % 23 - 11, 1.0 + f64::from(k % 7)), (3, 2.5)])
        })
        .collect();
    let before = ALLOCATIONS.load(Ordering::SeqCst);
    for (k, g) in grids.iter().enumerate() {
        avoider.set_pose(&nav_at(g.time.as_secs_f64(), 0.15 * k as f64, 0.05 * k as f64));
        avoider.update(g.time, g).expect("valid grid");
    }
    assert!(avoider.remembered() > 0, "the memory was exercised");
    avoider.check(at(10.0)).expect("stale by then");
    let after = ALLOCATIONS.load(Ordering::SeqCst);
    assert_eq!(after - before, 0, "avoider updates allocated");
}
