//! Compass calibration: an ellipsoid fit to readings taken while the vehicle is turned through
//! every orientation, giving the hard-iron offset and a symmetric soft-iron matrix such that
//! `soft_iron⁻¹ · (measured − hard_iron)` lies on a sphere of the expected field strength.
//!
//! An algebraic least-squares fit of the general quadric starts a Levenberg–Marquardt
//! refinement of the geometric residual `|soft_iron⁻¹ · (m − hard_iron)| − field` (what
//! ArduPilot's `CompassCalibrator` reports as fitness). The soft iron is scaled so the
//! corrected field has the *expected* strength (ArduPilot's `fix_radius`); the fitted strength
//! (the ellipsoid's geometric-mean radius) is checked against it. Magnitudes alone cannot see a
//! rotation, so a non-symmetric soft iron is recovered as its symmetric polar factor.

use kestrel_proto::calibration::{InvalidCalibration, MagCalibration, rows3};
use kestrel_proto::messages::MagSample;
use nalgebra::{Matrix3, SMatrix, SVector, SymmetricEigen, Vector3};

use crate::calibration::coverage::{Coverage, REGIONS};
use crate::calibration::still::{AXES, exceeds};

type Vector9 = SVector<f64, 9>;
type Matrix9 = SMatrix<f64, 9, 9>;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MagSettings {
    /// Strength of the Earth's field where the vehicle is (gauss): from the World Magnetic
    /// Model at the vehicle's position, or the simulator's world file.
    pub expected_field_gauss: f64,
    /// Fewest samples.
    pub min_samples: usize,
    /// Smallest 1σ spread of the readings along their flattest direction, as a share of the
    /// expected field: a sphere has 0.58, a hemisphere 0.29, one orientation only noise.
    pub min_spread: f64,
    /// Share of the 32 direction regions that must hold `min_region_samples` samples.
    pub min_coverage: f64,
    pub min_region_samples: u32,
    /// Largest RMS geometric residual (gauss); ArduPilot's `COMPASS_CAL_FIT` default is 16 mG.
    pub max_residual_gauss: f64,
    /// Fitted over expected strength must lie within this range.
    pub field_ratio: (f64, f64),
    /// Largest hard-iron offset per axis (gauss); ArduPilot's `COMPASS_OFFS_MAX` is 1.8 G.
    pub max_offset_gauss: f64,
    /// Largest ratio of the soft iron's strongest to weakest principal gain.
    pub max_anisotropy: f64,
}

impl MagSettings {
    /// Defaults around the field strength `expected_field_gauss`.
    pub fn new(expected_field_gauss: f64) -> MagSettings {
        MagSettings {
            expected_field_gauss,
            min_samples: 150,
            min_spread: 0.2,
            min_coverage: 0.75,
            min_region_samples: 2,
            max_residual_gauss: 0.016,
            field_ratio: (0.5, 1.5),
            max_offset_gauss: 1.8,
            max_anisotropy: 2.0,
        }
    }
}

/// A compass calibration and how good it is.
#[derive(Clone, Debug, PartialEq)]
pub struct MagFit {
    pub calibration: MagCalibration,
    /// RMS of `|corrected| − expected` over the samples (gauss): the fitness.
    pub residual_gauss: f64,
    /// Geometric-mean radius of the fitted ellipsoid (gauss).
    pub fitted_field_gauss: f64,
    pub expected_field_gauss: f64,
    /// Samples per direction region, of the corrected readings.
    pub coverage: Coverage,
    /// Regions holding enough samples, of [`REGIONS`].
    pub regions_covered: usize,
    pub samples: usize,
    /// First to last stamp (s).
    pub duration_s: f64,
    /// Refinement iterations run.
    pub iterations: usize,
}

impl MagFit {
    /// Fitted over expected field strength.
    pub fn field_ratio(&self) -> f64 {
        self.fitted_field_gauss / self.expected_field_gauss
    }
}

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MagCalError {
    #[error("expected field strength {0} G is not a positive number")]
    BadExpectedField(f64),
    #[error("{got} samples, at least {need} needed: keep turning the vehicle")]
    TooFewSamples { got: usize, need: usize },
    #[error("sample {index} is not finite: {field_gauss:?}")]
    NonFinite { index: usize, field_gauss: [f64; 3] },
    #[error(
        "the readings spread only {std_gauss:.4} G (1σ) along their flattest direction, at least {need_gauss:.4} G needed: the vehicle was held in one orientation or turned about one axis only; turn it through every orientation"
    )]
    NoSpread { std_gauss: f64, need_gauss: f64 },
    #[error("the readings fit no ellipsoid ({0}): turn the vehicle through every orientation")]
    NotAnEllipsoid(&'static str),
    #[error(
        "only {covered} of {regions} directions seen (at least {need} needed): turn the vehicle through the missing orientations"
    )]
    CoverageTooLow { covered: usize, regions: usize, need: usize },
    #[error(
        "the fit leaves {residual_gauss:.4} G RMS (at most {max_gauss}): the field changed during calibration (motors, metal nearby) or the vehicle moved too fast"
    )]
    ResidualTooHigh { residual_gauss: f64, max_gauss: f64 },
    #[error(
        "the fitted field is {fitted_gauss:.3} G, {ratio:.2}× the expected {expected_gauss:.3} G (allowed {min}..{max}×): magnetic interference or a wrong expected field"
    )]
    FieldStrength { fitted_gauss: f64, expected_gauss: f64, ratio: f64, min: f64, max: f64 },
    #[error(
        "{axis} hard-iron offset {offset_gauss:.3} G exceeds {max_gauss} G: a magnet or current next to the compass"
    )]
    OffsetTooLarge { axis: &'static str, offset_gauss: f64, max_gauss: f64 },
    #[error("the soft iron distorts the field {ratio:.2}:1 (at most {max}:1): iron too close to the compass")]
    SoftIronTooStrong { ratio: f64, max: f64 },
    #[error("compass calibration: {0}")]
    Invalid(#[from] InvalidCalibration),
}

/// Fits hard and soft iron to `samples` taken while the vehicle turned through every
/// orientation. The result does not depend on the samples' order.
pub fn calibrate_mag(samples: &[MagSample], settings: &MagSettings) -> Result<MagFit, MagCalError> {
    let field = settings.expected_field_gauss;
    if !(field.is_finite() && field > 0.0) {
        return Err(MagCalError::BadExpectedField(field));
    }
    if samples.len() < settings.min_samples.max(10) {
        return Err(MagCalError::TooFewSamples { got: samples.len(), need: settings.min_samples.max(10) });
    }
    if let Some((index, s)) =
        samples.iter().enumerate().find(|(_, s)| !s.field_gauss.iter().all(|v| v.is_finite()))
    {
        return Err(MagCalError::NonFinite { index, field_gauss: s.field_gauss });
    }
    let n = samples.len() as f64;
    let centre = samples.iter().fold(Vector3::zeros(), |a, s| a + Vector3::from(s.field_gauss)) / n;
    // Work in units of the expected field around the readings' centre, for conditioning.
    let points: Vec<Vector3<f64>> =
        samples.iter().map(|s| (Vector3::from(s.field_gauss) - centre) / field).collect();

    let covariance = points.iter().fold(Matrix3::zeros(), |a, p| a + p * p.transpose()) / n;
    let flattest = SymmetricEigen::new(covariance).eigenvalues.min().max(0.0).sqrt();
    if flattest < settings.min_spread {
        return Err(MagCalError::NoSpread {
            std_gauss: flattest * field,
            need_gauss: settings.min_spread * field,
        });
    }

    let (mut offset, mut gain) = algebraic_fit(&points)?;
    let iterations = refine(&points, &mut offset, &mut gain);
    let soft_iron = gain.try_inverse().ok_or(MagCalError::NotAnEllipsoid("singular after refinement"))?;
    let soft_iron = (soft_iron + soft_iron.transpose()) / 2.0;

    let corrected: Vec<Vector3<f64>> = points.iter().map(|p| gain * (p - offset)).collect();
    let coverage = Coverage::of(corrected.iter().copied());
    let regions_covered = coverage.covered(settings.min_region_samples);
    let need = (settings.min_coverage * REGIONS as f64).ceil() as usize;
    if regions_covered < need {
        return Err(MagCalError::CoverageTooLow { covered: regions_covered, regions: REGIONS, need });
    }
    let residual_gauss = field * (corrected.iter().map(|c| (c.norm() - 1.0).powi(2)).sum::<f64>() / n).sqrt();
    if exceeds(residual_gauss, settings.max_residual_gauss) {
        return Err(MagCalError::ResidualTooHigh { residual_gauss, max_gauss: settings.max_residual_gauss });
    }
    let eigen = SymmetricEigen::new(soft_iron).eigenvalues;
    let fitted_field_gauss = field * eigen.iter().product::<f64>().cbrt();
    let ratio = fitted_field_gauss / field;
    let (min, max) = settings.field_ratio;
    if !(min..=max).contains(&ratio) {
        return Err(MagCalError::FieldStrength {
            fitted_gauss: fitted_field_gauss,
            expected_gauss: field,
            ratio,
            min,
            max,
        });
    }
    let hard_iron = centre + offset * field;
    if let Some(axis) = (0..3).find(|&i| hard_iron[i].abs() > settings.max_offset_gauss) {
        return Err(MagCalError::OffsetTooLarge {
            axis: AXES[axis],
            offset_gauss: hard_iron[axis],
            max_gauss: settings.max_offset_gauss,
        });
    }
    let anisotropy = eigen.max() / eigen.min();
    if exceeds(anisotropy, settings.max_anisotropy) {
        return Err(MagCalError::SoftIronTooStrong { ratio: anisotropy, max: settings.max_anisotropy });
    }
    let first = samples.iter().map(|s| s.time).fold(samples[0].time, std::cmp::min);
    let last = samples.iter().map(|s| s.time).fold(samples[0].time, std::cmp::max);
    Ok(MagFit {
        calibration: MagCalibration::new(hard_iron.into(), rows3(&soft_iron))?,
        residual_gauss,
        fitted_field_gauss,
        expected_field_gauss: field,
        coverage,
        regions_covered,
        samples: samples.len(),
        duration_s: last.saturating_since(first).as_secs_f64(),
        iterations,
    })
}

/// The ellipsoid `(p − offset)ᵀ A (p − offset) = 1` by linear least squares on the quadric
/// `a x² + b y² + c z² + 2d xy + 2e xz + 2f yz + 2g x + 2h y + 2i z = 1`; returns the offset and
/// `gain = A^½`, the symmetric matrix mapping the ellipsoid onto the unit sphere.
fn algebraic_fit(points: &[Vector3<f64>]) -> Result<(Vector3<f64>, Matrix3<f64>), MagCalError> {
    let mut normal = Matrix9::zeros();
    let mut rhs = Vector9::zeros();
    for p in points {
        let (x, y, z) = (p.x, p.y, p.z);
        let row = Vector9::from([
            x * x,
            y * y,
            z * z,
            2.0 * x * y,
            2.0 * x * z,
            2.0 * y * z,
            2.0 * x,
            2.0 * y,
            2.0 * z,
        ]);
        normal += row * row.transpose();
        rhs += row;
    }
    let q = normal.cholesky().ok_or(MagCalError::NotAnEllipsoid("the quadric is undetermined"))?.solve(&rhs);
    let a0 = Matrix3::new(q[0], q[3], q[4], q[3], q[1], q[5], q[4], q[5], q[2]);
    let linear = Vector3::new(q[6], q[7], q[8]);
    let offset = -a0.try_inverse().ok_or(MagCalError::NotAnEllipsoid("the quadric has no centre"))? * linear;
    let k = 1.0 + offset.dot(&(a0 * offset));
    let a = a0 / k;
    let eigen = SymmetricEigen::new(a);
    if !(k > 0.0 && eigen.eigenvalues.iter().all(|&l| l > 0.0 && l.is_finite())) {
        return Err(MagCalError::NotAnEllipsoid("the quadric is not an ellipsoid"));
    }
    let root = eigen.eigenvectors
        * Matrix3::from_diagonal(&eigen.eigenvalues.map(f64::sqrt))
        * eigen.eigenvectors.transpose();
    Ok((offset, (root + root.transpose()) / 2.0))
}

/// Sum of squared geometric residuals `|gain · (p − offset)| − 1`.
fn cost(points: &[Vector3<f64>], offset: &Vector3<f64>, gain: &Matrix3<f64>) -> f64 {
    points.iter().map(|p| ((gain * (p - offset)).norm() - 1.0).powi(2)).sum()
}

/// `gain` with the symmetric step `d` (diagonal, then xy, xz, yz) added.
fn step_gain(gain: &Matrix3<f64>, d: &[f64]) -> Matrix3<f64> {
    gain + Matrix3::new(d[0], d[3], d[4], d[3], d[1], d[5], d[4], d[5], d[2])
}

/// Levenberg–Marquardt on the offset (3) and symmetric gain (6); returns the iterations run.
fn refine(points: &[Vector3<f64>], offset: &mut Vector3<f64>, gain: &mut Matrix3<f64>) -> usize {
    const MAX_ITERATIONS: usize = 50;
    let mut lambda = 1e-3;
    let mut current = cost(points, offset, gain);
    for iteration in 0..MAX_ITERATIONS {
        let mut jtj = Matrix9::zeros();
        let mut jtr = Vector9::zeros();
        for p in points {
            let z = *p - *offset;
            let w = *gain * z;
            let norm = w.norm();
            if norm < 1e-12 {
                continue;
            }
            let dw = *gain * w / norm;
            let row = Vector9::from([
                -dw.x,
                -dw.y,
                -dw.z,
                w.x * z.x / norm,
                w.y * z.y / norm,
                w.z * z.z / norm,
                (w.x * z.y + w.y * z.x) / norm,
                (w.x * z.z + w.z * z.x) / norm,
                (w.y * z.z + w.z * z.y) / norm,
            ]);
            jtj += row * row.transpose();
            jtr += row * (norm - 1.0);
        }
        let mut improved = false;
        while lambda < 1e12 {
            let damped = jtj + Matrix9::from_diagonal(&jtj.diagonal()) * lambda;
            let Some(step) = damped.cholesky().map(|c| c.solve(&-jtr)) else {
                lambda *= 10.0;
                continue;
            };
            let trial_offset = *offset + Vector3::new(step[0], step[1], step[2]);
            let trial_gain = step_gain(gain, &step.as_slice()[3..]);
            let trial = cost(points, &trial_offset, &trial_gain);
            if trial < current {
                let converged = current - trial <= 1e-14 * current.max(1e-300) || step.norm() < 1e-13;
                (*offset, *gain, current) = (trial_offset, trial_gain, trial);
                lambda = (lambda / 10.0).max(1e-12);
                improved = !converged;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            return iteration + 1;
        }
    }
    MAX_ITERATIONS
}
