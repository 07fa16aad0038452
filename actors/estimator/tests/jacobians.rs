//! The analytic transition `F` and input matrix `G` against finite differences of the actual
//! propagation, and the covariance and quaternion invariants over long random runs.

use kestrel_estimator::covariance::{ProcessNoise, SparseRow, fuse_scalar};
use kestrel_estimator::filter::propagate;
use kestrel_estimator::state::{Covariance, ERROR_STATES, ErrorVector, ImuDelta, State};
use kestrel_proto::Time;
use nalgebra::{UnitQuaternion, Vector3};
use proptest::prelude::*;

fn state(euler: [f64; 3], vel: [f64; 3], gyro_bias: [f64; 3], accel_bias: [f64; 3]) -> State {
    State {
        time: Time::ZERO,
        attitude: UnitQuaternion::from_euler_angles(euler[0], euler[1], euler[2]),
        vel_ned_m_s: Vector3::from(vel),
        pos_ned_m: Vector3::new(3.0, -2.0, -10.0),
        gyro_bias_rad_s: Vector3::from(gyro_bias),
        accel_bias_m_s2: Vector3::from(accel_bias),
    }
}

fn imu(gyro: [f64; 3], accel: [f64; 3]) -> ImuDelta {
    ImuDelta::from_rates(Time::from_micros(2500), gyro, accel, 0.0025)
}

/// Worst `|analytic − numeric|` relative to a scale of `1e-4 + |analytic|`.
fn worst_mismatch<const C: usize>(
    analytic: &nalgebra::SMatrix<f64, ERROR_STATES, C>,
    numeric: &nalgebra::SMatrix<f64, ERROR_STATES, C>,
) -> f64 {
    analytic.zip_map(numeric, |a, n| (a - n).abs() / (1e-4 + a.abs())).max()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn f_matches_finite_differences(
        euler in prop::array::uniform3(-1.0f64..1.0),
        vel in prop::array::uniform3(-5.0f64..5.0),
        bg in prop::array::uniform3(-0.02f64..0.02),
        ba in prop::array::uniform3(-0.3f64..0.3),
        gyro in prop::array::uniform3(-2.0f64..2.0),
        accel in prop::array::uniform3(-12.0f64..12.0),
    ) {
        let x = state(euler, vel, bg, ba);
        let u = imu(gyro, accel);
        let (_, transition) = propagate(&x, &u);
        let f = transition.dense_f();
        let eps = 1e-6;
        let mut numeric = Covariance::zeros();
        for j in 0..ERROR_STATES {
            let mut dx = ErrorVector::zeros();
            dx[j] = eps;
            let plus = propagate(&x.boxplus(&dx), &u).0;
            let minus = propagate(&x.boxplus(&-dx), &u).0;
            numeric.set_column(j, &(plus.boxminus(&minus) / (2.0 * eps)));
        }
        let worst = worst_mismatch(&f, &numeric);
        prop_assert!(worst < 5e-3, "worst relative mismatch {worst}\nF = {f}\nnumeric = {numeric}");
    }

    #[test]
    fn g_matches_finite_differences(
        euler in prop::array::uniform3(-1.0f64..1.0),
        gyro in prop::array::uniform3(-2.0f64..2.0),
        accel in prop::array::uniform3(-12.0f64..12.0),
    ) {
        let x = state(euler, [1.0, -1.0, 0.5], [0.0; 3], [0.0; 3]);
        let (_, transition) = propagate(&x, &imu(gyro, accel));
        let g = transition.dense_g();
        let eps = 1e-5;
        let mut numeric = nalgebra::SMatrix::<f64, ERROR_STATES, 6>::zeros();
        for j in 0..6 {
            let perturbed = |sign: f64| {
                let (mut gy, mut ac) = (gyro, accel);
                if j < 3 { gy[j] += sign * eps } else { ac[j - 3] += sign * eps }
                propagate(&x, &imu(gy, ac)).0
            };
            numeric.set_column(j, &(perturbed(1.0).boxminus(&perturbed(-1.0)) / (2.0 * eps)));
        }
        let worst = worst_mismatch(&g, &numeric);
        prop_assert!(worst < 5e-3, "worst relative mismatch {worst}\nG = {g}\nnumeric = {numeric}");
    }

    #[test]
    fn covariance_stays_symmetric_positive_definite_and_quaternion_unit(
        seed_rates in prop::collection::vec(prop::array::uniform3(-3.0f64..3.0), 20),
        observe_every in 3usize..40,
    ) {
        let mut x = state([0.1, -0.2, 0.3], [0.0; 3], [0.0; 3], [0.0; 3]);
        let mut p = Covariance::identity() * 0.01;
        let noise = ProcessNoise { gyro_rad_s: 0.015, accel_m_s2: 0.25, gyro_bias_rad_s2: 1e-3, accel_bias_m_s3: 3e-3 };
        for step in 0..20_000usize {
            let rates = seed_rates[step / 1000];
            let accel = [rates[1], rates[2], -9.8 + rates[0]];
            let (next, t) = propagate(&x, &imu(rates, accel));
            x = next;
            t.predict(&mut p, &noise).expect("finite covariance");
            if step % observe_every == 0 {
                let row = match step % 4 {
                    0 => SparseRow::unit(6 + step % 3),
                    1 => SparseRow::unit(3 + step % 3),
                    2 => SparseRow::block3(0, [0.3, -0.1, 0.4]),
                    _ => SparseRow::unit(8),
                };
                let dx = fuse_scalar(&mut p, &row, 0.1, 0.25).expect("healthy covariance fuses");
                x = x.boxplus(&dx);
            }
        }
        let asym = (p - p.transpose()).abs().max();
        prop_assert!(asym == 0.0 || asym < 1e-12 * p.abs().max(), "asymmetry {asym}");
        prop_assert!(p.cholesky().is_some(), "not positive definite: {p}");
        prop_assert!((x.attitude.into_inner().norm() - 1.0).abs() < 1e-12);
    }
}
