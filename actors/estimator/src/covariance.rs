//! Covariance prediction `P ← F P Fᵀ + G N Gᵀ` exploiting the sparsity of `F`, sequential
//! scalar fusion, and the limits that keep `P` symmetric positive definite.
//!
//! `F` (see [`Transition`]) has only three non-trivial 3×3 blocks, so `F X` costs three 3×3
//! by 3×15 products instead of a dense 15×15 product; `F P Fᵀ = F (F P)ᵀ` applies it twice.

use nalgebra::{Matrix3, SMatrix};

use crate::state::{ACCEL_BIAS, ATT, Covariance, ERROR_STATES, ErrorVector, GYRO_BIAS, POS, VEL};

/// The error-state transition of one IMU step, by its non-trivial blocks (eq. 3.14, 3.16).
///
/// With `R` the body→NED rotation after the step, `Δθ`, `Δv` the bias-corrected angle and
/// velocity increments, `J ≈ I − ½[Δθ]×` the right Jacobian of the rotation and `dt` the step:
/// ```text
///        δθ        δv    δp   δb_g          δb_a
/// δθ  [  I          0     0    A             0   ]      A = −R·J·dt
/// δv  [  B          I     0    B·A           C   ]      B = −[R·Δv]×,  C = −R·dt
/// δp  [  h·B      dt·I    I    h·B·A        h·C  ]      h = dt/2
/// δb  [  0          0     0    I             0   ]
/// ```
/// The response to the measured gyro and accelerometer inputs (eq. 3.16) is
/// `G = −[A, 0; B·A, C; h·B·A, h·C; 0, 0]`; their white noise enters as `G N Gᵀ` (eq. 3.18),
/// computed in closed form with `A Aᵀ ≈ C Cᵀ = dt² I` (exact up to `O(|Δθ|²)`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transition {
    pub a: Matrix3<f64>,
    pub b: Matrix3<f64>,
    pub c: Matrix3<f64>,
    pub dt_s: f64,
}

/// Process noise per step, from the white noises and bias random walks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProcessNoise {
    /// Gyro white noise (rad/s).
    pub gyro_rad_s: f64,
    /// Accelerometer white noise (m/s²).
    pub accel_m_s2: f64,
    /// Gyro bias random walk (rad/s²).
    pub gyro_bias_rad_s2: f64,
    /// Accelerometer bias random walk (m/s³).
    pub accel_bias_m_s3: f64,
}

/// Variance limits per block: (floor, cap), in the block's unit squared.
const LIMITS: [(usize, f64, f64); 5] = [
    (ATT, 1e-12, 1.0),
    (VEL, 1e-8, 1e4),
    (POS, 1e-8, 1e8),
    (GYRO_BIAS, 1e-14, 0.04),
    (ACCEL_BIAS, 1e-12, 1.0),
];

impl Transition {
    /// `F X` for any 15×15 `X`.
    pub fn left_mul(&self, x: &Covariance) -> Covariance {
        let h = 0.5 * self.dt_s;
        let x_v = x.fixed_view::<3, ERROR_STATES>(VEL, 0);
        let y_att =
            x.fixed_view::<3, ERROR_STATES>(ATT, 0) + self.a * x.fixed_view::<3, ERROR_STATES>(GYRO_BIAS, 0);
        let y_v = x_v + self.b * y_att + self.c * x.fixed_view::<3, ERROR_STATES>(ACCEL_BIAS, 0);
        let y_p = x.fixed_view::<3, ERROR_STATES>(POS, 0) + x_v * self.dt_s + (y_v - x_v) * h;
        let mut y = *x;
        y.fixed_view_mut::<3, ERROR_STATES>(ATT, 0).copy_from(&y_att);
        y.fixed_view_mut::<3, ERROR_STATES>(VEL, 0).copy_from(&y_v);
        y.fixed_view_mut::<3, ERROR_STATES>(POS, 0).copy_from(&y_p);
        y
    }

    /// `F` as a dense matrix, for tests and the dense reference benchmark.
    pub fn dense_f(&self) -> Covariance {
        self.left_mul(&Covariance::identity())
    }

    /// `G = ∂f/∂u`, the error-state response to the gyro (columns 0..3) and accelerometer
    /// (3..6) readings.
    pub fn dense_g(&self) -> SMatrix<f64, ERROR_STATES, 6> {
        let h = 0.5 * self.dt_s;
        let ba = self.b * self.a;
        let mut g = SMatrix::<f64, ERROR_STATES, 6>::zeros();
        g.fixed_view_mut::<3, 3>(ATT, 0).copy_from(&self.a);
        g.fixed_view_mut::<3, 3>(VEL, 0).copy_from(&ba);
        g.fixed_view_mut::<3, 3>(POS, 0).copy_from(&(ba * h));
        g.fixed_view_mut::<3, 3>(VEL, 3).copy_from(&self.c);
        g.fixed_view_mut::<3, 3>(POS, 3).copy_from(&(self.c * h));
        -g
    }

    /// `P ← F P Fᵀ + G N Gᵀ + Q_bias`, then limited; an error when `P` is no longer finite
    /// (the caller must reset it).
    pub fn predict(&self, p: &mut Covariance, noise: &ProcessNoise) -> Result<(), NotFinite> {
        let fp = self.left_mul(p);
        *p = self.left_mul(&fp.transpose());
        self.add_process_noise(p, noise);
        constrain(p)
    }

    /// Adds `G N Gᵀ` in closed form (`A Aᵀ ≈ C Cᵀ = dt² I` because `R` is a rotation) and the bias
    /// random walks.
    fn add_process_noise(&self, p: &mut Covariance, noise: &ProcessNoise) {
        let dt2 = self.dt_s * self.dt_s;
        let h = 0.5 * self.dt_s;
        let qg = noise.gyro_rad_s.powi(2) * dt2;
        let qa = noise.accel_m_s2.powi(2) * dt2;
        let bt = self.b.transpose();
        let bbt = self.b * bt;
        let id = Matrix3::identity();
        let blocks = [
            (ATT, ATT, id * qg),
            (ATT, VEL, bt * qg),
            (ATT, POS, bt * (qg * h)),
            (VEL, VEL, bbt * qg + id * qa),
            (VEL, POS, bbt * (qg * h) + id * (qa * h)),
            (POS, POS, bbt * (qg * h * h) + id * (qa * h * h)),
        ];
        for (r, c, q) in blocks {
            let mut view = p.fixed_view_mut::<3, 3>(r, c);
            view += q;
            if r != c {
                let mut mirror = p.fixed_view_mut::<3, 3>(c, r);
                mirror += q.transpose();
            }
        }
        let qbg = (noise.gyro_bias_rad_s2 * self.dt_s).powi(2);
        let qba = (noise.accel_bias_m_s3 * self.dt_s).powi(2);
        for i in 0..3 {
            p[(GYRO_BIAS + i, GYRO_BIAS + i)] += qbg;
            p[(ACCEL_BIAS + i, ACCEL_BIAS + i)] += qba;
        }
    }
}

/// A covariance element that is NaN or infinite: no limit can repair it (a NaN off-diagonal
/// would spread into every gain), so the filter must reset the covariance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("covariance element ({row}, {col}) is not finite")]
pub struct NotFinite {
    pub row: usize,
    pub col: usize,
}

/// The first non-finite element of `p`, if any.
pub fn check_finite(p: &Covariance) -> Result<(), NotFinite> {
    match p.iter().position(|x| !x.is_finite()) {
        // nalgebra stores columns one after the other.
        Some(i) => Err(NotFinite { row: i % ERROR_STATES, col: i / ERROR_STATES }),
        None => Ok(()),
    }
}

/// Keeps every variance within its block's floor and cap. A variance above its cap scales its
/// row and column down, which keeps the matrix positive semi-definite. A `p` with any
/// non-finite element is refused untouched: clamping its diagonal would hide the fault while
/// a NaN correlation still poisons every later gain.
pub fn constrain(p: &mut Covariance) -> Result<(), NotFinite> {
    check_finite(p)?;
    for (start, floor, cap) in LIMITS {
        for i in start..start + 3 {
            let v = p[(i, i)];
            if v < floor {
                p[(i, i)] = floor;
            } else if v > cap {
                let s = (cap / v).sqrt();
                for j in 0..ERROR_STATES {
                    p[(i, j)] *= s;
                    p[(j, i)] *= s;
                }
            }
        }
    }
    Ok(())
}

/// Makes `p` exactly symmetric.
pub fn symmetrize(p: &mut Covariance) {
    for i in 0..ERROR_STATES {
        for j in i + 1..ERROR_STATES {
            let m = 0.5 * (p[(i, j)] + p[(j, i)]);
            p[(i, j)] = m;
            p[(j, i)] = m;
        }
    }
}

/// A measurement Jacobian row with at most three non-zero entries (every observation here).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SparseRow {
    entries: [(usize, f64); 3],
    len: usize,
}

impl SparseRow {
    /// A row that observes state `index` directly.
    pub fn unit(index: usize) -> SparseRow {
        SparseRow { entries: [(index, 1.0), (0, 0.0), (0, 0.0)], len: 1 }
    }

    /// A row with the single entry `value` at state `index`.
    pub fn unit_scaled(index: usize, value: f64) -> SparseRow {
        SparseRow { entries: [(index, value), (0, 0.0), (0, 0.0)], len: 1 }
    }

    /// A row with entries at three consecutive states starting at `start`.
    pub fn block3(start: usize, values: [f64; 3]) -> SparseRow {
        SparseRow { entries: [(start, values[0]), (start + 1, values[1]), (start + 2, values[2])], len: 3 }
    }

    /// The non-zero entries.
    pub fn entries(&self) -> &[(usize, f64)] {
        &self.entries[..self.len]
    }

    /// `h · x`.
    pub fn dot(&self, x: &ErrorVector) -> f64 {
        self.entries().iter().map(|&(i, v)| v * x[i]).sum()
    }

    /// `P hᵀ`.
    pub fn p_ht(&self, p: &Covariance) -> ErrorVector {
        let mut out = ErrorVector::zeros();
        for &(i, v) in self.entries() {
            out.axpy(v, &p.column(i), 1.0);
        }
        out
    }

    /// Innovation variance `h P hᵀ + r`.
    pub fn innovation_variance(&self, p: &Covariance, obs_variance: f64) -> f64 {
        self.dot(&self.p_ht(p)) + obs_variance
    }

    /// Dense form, for tests and the dense reference benchmark.
    pub fn dense(&self) -> SMatrix<f64, 1, ERROR_STATES> {
        let mut h = SMatrix::<f64, 1, ERROR_STATES>::zeros();
        for &(i, v) in self.entries() {
            h[i] += v;
        }
        h
    }
}

/// Why a fusion was skipped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FusionFault {
    /// The innovation, or the correction it implies, was not finite.
    #[error("innovation is not finite")]
    BadInnovation,
    /// The innovation variance was not positive and finite.
    #[error("innovation variance is not positive")]
    BadInnovationVariance,
    /// The update would have driven a variance below zero (the covariance had lost positive
    /// definiteness to rounding).
    #[error("update would make a variance negative")]
    NegativeVariance,
    /// The covariance was not finite (before or after the update); it must be reset.
    #[error(transparent)]
    Covariance(#[from] NotFinite),
}

/// Scalar Kalman update of `p` for observation row `h`, innovation `y` and observation variance
/// `r` (eq. 3.24–3.27). Returns the error-state correction `K y`.
///
/// The covariance update `P − (P hᵀ)(P hᵀ)ᵀ / S` is the Joseph form's value for the optimal gain,
/// computed as a symmetric rank-one downdate, so it stays symmetric by construction; a
/// downdate that would make any variance negative is refused (PX4 EKF2 does the same).
pub fn fuse_scalar(p: &mut Covariance, h: &SparseRow, y: f64, r: f64) -> Result<ErrorVector, FusionFault> {
    if !y.is_finite() {
        return Err(FusionFault::BadInnovation);
    }
    check_finite(p)?;
    let pht = h.p_ht(p);
    let s = h.dot(&pht) + r;
    if !(s.is_finite() && s > 0.0) {
        return Err(FusionFault::BadInnovationVariance);
    }
    let inv_s = 1.0 / s;
    // Checked before `p` is touched, so a refused update never leaves the filter more confident.
    let correction = pht * (y * inv_s);
    if !correction.iter().all(|c| c.is_finite()) {
        return Err(FusionFault::BadInnovation);
    }
    for i in 0..ERROR_STATES {
        if p[(i, i)] - pht[i] * pht[i] * inv_s < 0.0 {
            return Err(FusionFault::NegativeVariance);
        }
    }
    for j in 0..ERROR_STATES {
        let kj = pht[j] * inv_s;
        for i in 0..ERROR_STATES {
            p[(i, j)] -= pht[i] * kj;
        }
    }
    symmetrize(p);
    constrain(p)?;
    Ok(correction)
}

/// Forgets every correlation of the states `start..start + len` and sets their variance to
/// `variance` (after a reset of those states to a measurement).
pub fn reset_block(p: &mut Covariance, start: usize, len: usize, variance: f64) {
    for i in start..start + len {
        for j in 0..ERROR_STATES {
            p[(i, j)] = 0.0;
            p[(j, i)] = 0.0;
        }
        p[(i, i)] = variance;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_refused_update_leaves_the_covariance_untouched() {
        let mut p = Covariance::identity();
        let before = p;
        let h = SparseRow::unit(3);
        assert_eq!(fuse_scalar(&mut p, &h, f64::NAN, 1.0).unwrap_err(), FusionFault::BadInnovation);
        assert_eq!(fuse_scalar(&mut p, &h, f64::INFINITY, 1.0).unwrap_err(), FusionFault::BadInnovation);
        assert_eq!(fuse_scalar(&mut p, &h, 1.0, f64::NAN).unwrap_err(), FusionFault::BadInnovationVariance);
        assert_eq!(p, before, "no fusion happened, so no confidence was gained");
        let dx = fuse_scalar(&mut p, &h, 1.0, 1.0).unwrap();
        assert!((p[(3, 3)] - 0.5).abs() < 1e-12 && (dx[3] - 0.5).abs() < 1e-12);
    }

    #[test]
    fn a_nan_correlation_is_refused_not_clamped() {
        let mut p = Covariance::identity();
        p[(7, 2)] = f64::NAN;
        p[(2, 7)] = f64::NAN;
        let before = p;
        assert_eq!(constrain(&mut p), Err(NotFinite { row: 7, col: 2 }));
        let h = SparseRow::unit(2);
        assert_eq!(
            fuse_scalar(&mut p, &h, 0.1, 1.0),
            Err(FusionFault::Covariance(NotFinite { row: 7, col: 2 }))
        );
        let t =
            Transition { a: Matrix3::identity(), b: Matrix3::zeros(), c: Matrix3::identity(), dt_s: 0.01 };
        let noise =
            ProcessNoise { gyro_rad_s: 0.01, accel_m_s2: 0.1, gyro_bias_rad_s2: 1e-4, accel_bias_m_s3: 1e-3 };
        // The refused calls left `p` as it was (the NaN included), for the filter to reset.
        assert_eq!(p.map(f64::is_nan), before.map(f64::is_nan));
        assert_eq!(p[(1, 1)], before[(1, 1)]);
        assert!(t.predict(&mut p, &noise).is_err());
        let mut inf = Covariance::identity();
        inf[(0, 0)] = f64::INFINITY;
        assert_eq!(constrain(&mut inf), Err(NotFinite { row: 0, col: 0 }));
    }
}
