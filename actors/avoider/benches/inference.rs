//! One inference of the thesis's avoider rule base (config/avoider/thesis.fll), cycling over
//! 64 fixed input vectors. scripts/fuzzy_bench.py times pyfuzzylite on the same vectors.
//! Goal: under 10 µs per inference (the thesis's fuzzylite C++ took about 10 ms, §3.3.2).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use kestrel_avoider::thesis_engine;

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

criterion_group!(benches, thesis_inference);
criterion_main!(benches);
