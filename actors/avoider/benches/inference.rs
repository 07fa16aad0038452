//! One inference of the thesis's avoider rule base (config/avoider/thesis.fll), cycling over
//! 64 fixed input vectors. scripts/fuzzy_bench.py times pyfuzzylite on the same vectors.
//! Goal: under 10 µs per inference (the thesis's fuzzylite C++ took about 10 ms, §3.3.2).
//! Beside it, one whole avoider update: a depth grid (the same vectors as near shares) in, an
//! `AvoidanceCommand` out.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use kestrel_avoider::{Avoider, AvoiderParams, thesis_engine};
use kestrel_proto::Time;
use kestrel_proto::messages::{DepthGrid, GridRegion, ObstacleSectors};

/// Input vector `k`: input `j` is the fractional part of `(10k + j + 1) · φ` (golden ratio),
/// the same formula as scripts/fuzzy_bench.py.
fn inputs(count: usize) -> Vec<[f64; 10]> {
    let phi = 0.618_033_988_749_894_9_f64;
    (0..count).map(|k| std::array::from_fn(|j| (((10 * k + j + 1) as f64) * phi).fract())).collect()
}

fn thesis_inference(c: &mut Criterion) {
    let engine = thesis_engine().expect("the shipped rule base loads");
    let mut workspace = engine.workspace();
    let vectors = inputs(64);
    let mut k = 0;
    c.bench_function("thesis rule base, one inference", |b| {
        b.iter(|| {
            k = (k + 1) % vectors.len();
            let out = engine.infer(&mut workspace, black_box(&vectors[k])).expect("valid inputs");
            black_box(out[0] + out[1] + out[2])
        })
    });
}

fn avoider_update(c: &mut Criterion) {
    let mut avoider = Avoider::thesis(AvoiderParams::default()).expect("builds");
    let mut grids: Vec<DepthGrid> = inputs(64)
        .iter()
        .map(|v| DepthGrid {
            time: Time::ZERO,
            frame_sequence: 0,
            threshold_m: 5.0,
            regions: std::array::from_fn(|row| {
                std::array::from_fn(|col| GridRegion {
                    near_share: v[3 * row + col] as f32,
                    invalid_share: v[(3 * row + col + 1) % 10] as f32,
                    nearest_m: Some(3.0),
                })
            }),
            sectors: ObstacleSectors {
                distances_cm: Vec::new(),
                increment_deg: 5.0,
                angle_offset_deg: 0.0,
                min_distance_cm: 30,
                max_distance_cm: 2000,
            },
        })
        .collect();
    let mut frame = 0u64;
    c.bench_function("avoider update, depth grid to command", |b| {
        b.iter(|| {
            frame += 1;
            let grid = &mut grids[(frame % 64) as usize];
            // Stamps must increase, at the stereo engine's 15 Hz.
            grid.time = black_box(Time::from_micros(frame * 66_667));
            black_box(avoider.update(grid.time, grid).expect("valid grid").velocity_frd_m_s)
        })
    });
}

criterion_group!(benches, thesis_inference, avoider_update);
criterion_main!(benches);
