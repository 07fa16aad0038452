//! The filter's hot steps beside a straightforward dense nalgebra version of the same step:
//! `cargo bench -p kestrel-estimator --bench ekf`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use kestrel_estimator::covariance::{ProcessNoise, SparseRow, Transition, constrain, fuse_scalar};
use kestrel_estimator::filter::{Filter, propagate};
use kestrel_estimator::output_predictor::OutputPredictor;
use kestrel_estimator::state::{Covariance, ImuDelta, State};
use kestrel_proto::Time;
use nalgebra::{SMatrix, UnitQuaternion, Vector3};

const NOISE: ProcessNoise =
    ProcessNoise { gyro_rad_s: 0.015, accel_m_s2: 0.25, gyro_bias_rad_s2: 1e-3, accel_bias_m_s3: 3e-3 };

fn filter() -> Filter {
    let state = State {
        vel_ned_m_s: Vector3::new(2.0, -1.0, 0.3),
        ..State::at_rest(Time::ZERO, UnitQuaternion::from_euler_angles(0.1, -0.05, 1.0))
    };
    let mut f = Filter::aligned(state, true);
    // Fill the correlations as a running filter has them.
    for k in 0..400u64 {
        f.predict(&imu(k), &NOISE);
    }
    f
}

fn imu(k: u64) -> ImuDelta {
    ImuDelta::from_rates(Time::from_micros(2500 * (k + 1)), [0.1, -0.2, 0.3], [0.3, -0.2, -9.7], 0.0025)
}

/// `F P Fᵀ + G N Gᵀ + Q_bias` with dense 15×15 products.
fn dense_predict(p: &mut Covariance, t: &Transition) {
    let f = t.dense_f();
    let g = t.dense_g();
    let mut n = SMatrix::<f64, 6, 6>::zeros();
    for i in 0..3 {
        n[(i, i)] = NOISE.gyro_rad_s.powi(2);
        n[(i + 3, i + 3)] = NOISE.accel_m_s2.powi(2);
    }
    *p = f * *p * f.transpose() + g * n * g.transpose();
    for i in 0..3 {
        p[(9 + i, 9 + i)] += (NOISE.gyro_bias_rad_s2 * t.dt_s).powi(2);
        p[(12 + i, 12 + i)] += (NOISE.accel_bias_m_s3 * t.dt_s).powi(2);
    }
    constrain(p).expect("finite covariance");
}

/// The textbook update `K = P Hᵀ / S`, `P = (I − K H) P`, symmetrised, with dense matrices.
fn dense_fuse(p: &mut Covariance, h: &SparseRow, r: f64) {
    let h = h.dense();
    let s = (h * *p * h.transpose())[(0, 0)] + r;
    let k = *p * h.transpose() / s;
    *p = (Covariance::identity() - k * h) * *p;
    *p = (*p + p.transpose()) * 0.5;
    constrain(p).expect("finite covariance");
}

fn gps_rows() -> [SparseRow; 5] {
    [3, 4, 5, 6, 7].map(SparseRow::unit)
}

fn mag_rows() -> [SparseRow; 3] {
    [0.2, -0.35, 0.05].map(|v| SparseRow::unit_scaled(2, v))
}

fn benches(c: &mut Criterion) {
    let base = filter();
    let mut g = c.benchmark_group("predict");
    g.bench_function("sparse", |b| {
        let mut f = base.clone();
        let mut k = 0;
        b.iter(|| {
            k += 1;
            f.predict(black_box(&imu(k)), &NOISE);
        })
    });
    g.bench_function("dense", |b| {
        let mut f = base.clone();
        let mut k = 0;
        b.iter(|| {
            k += 1;
            let (next, t) = propagate(&f.state, black_box(&imu(k)));
            f.state = next;
            dense_predict(&mut f.cov, &t);
        })
    });
    g.finish();

    let mut g = c.benchmark_group("imu_step");
    g.bench_function("predict_and_output_predictor", |b| {
        let mut f = base.clone();
        let mut out = OutputPredictor::new(&f.state, 1024, 0.22, 0.25);
        let mut k = 400;
        b.iter(|| {
            k += 1;
            let d = imu(k);
            out.predict(&d, &f.state.gyro_bias_rad_s, &f.state.accel_bias_m_s2);
            f.predict(black_box(&d), &NOISE);
            out.correct(&f.state, d.dt_s);
        })
    });
    g.finish();

    for (name, rows) in [("gps_fusion", gps_rows().to_vec()), ("mag_fusion", mag_rows().to_vec())] {
        let mut g = c.benchmark_group(name);
        g.bench_function("sparse", |b| {
            b.iter_batched_ref(
                || base.cov,
                |p| {
                    for h in &rows {
                        let _ = black_box(fuse_scalar(p, h, 0.1, 0.25));
                    }
                },
                criterion::BatchSize::SmallInput,
            )
        });
        g.bench_function("dense", |b| {
            b.iter_batched_ref(
                || base.cov,
                |p| {
                    for h in &rows {
                        dense_fuse(p, h, 0.25);
                    }
                    black_box(p[(0, 0)]);
                },
                criterion::BatchSize::SmallInput,
            )
        });
        g.finish();
    }
}

criterion_group!(ekf, benches);
criterion_main!(ekf);
