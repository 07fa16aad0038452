//! Defuzzifiers: from an aggregated fuzzy set back to one crisp number.
//!
//! The integral methods sample the output range at `resolution` midpoints
//! (`min + (i + ½)·(max − min)/resolution`, the midpoint rectangle rule) and follow fuzzylite 8
//! exactly: the maximum methods take the samples whose membership equals the largest one (and
//! is above zero); the bisector takes the sample(s) where the cumulative area is nearest half the
//! total. With no activation at all the result is NaN, which the output variable may replace by
//! its default value.

use crate::term::Term;

/// How an output variable is turned into a crisp value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Defuzzifier {
    /// Methods that sample the aggregated membership function over the output range.
    Integral {
        method: IntegralMethod,
        /// Number of samples over the range.
        resolution: usize,
    },
    /// Methods that combine the activated terms' degrees directly (Takagi–Sugeno, Tsukamoto).
    Weighted {
        method: WeightedMethod,
        /// Which value of each activated term is weighted; `Automatic` infers it from the terms.
        kind: WeightedKind,
    },
}

/// Integral defuzzifiers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IntegralMethod {
    /// Centre of gravity `Σ x·μ(x) / Σ μ(x)` (the thesis's choice, §3.3.7).
    Centroid,
    /// The `x` splitting the area under `μ` in two equal halves.
    Bisector,
    /// Mean of the samples where `μ` is largest.
    MeanOfMaximum,
    /// Smallest sample where `μ` is largest.
    SmallestOfMaximum,
    /// Largest sample where `μ` is largest.
    LargestOfMaximum,
}

/// Weighted defuzzifiers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WeightedMethod {
    /// `Σ wᵢ zᵢ / Σ wᵢ`.
    WeightedAverage,
    /// `Σ wᵢ zᵢ` (NaN when no term is activated at all, as fuzzylite).
    WeightedSum,
}

/// What `zᵢ` is for an activated term of degree `wᵢ` in a weighted defuzzifier.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WeightedKind {
    /// Inferred from the output's terms: Constant terms → Takagi–Sugeno, monotonic terms
    /// (Ramp, Sigmoid) → Tsukamoto, other shapes → the membership at `wᵢ` (fuzzylite's
    /// "inverse Tsukamoto").
    Automatic,
    /// `zᵢ = μᵢ(wᵢ)`.
    TakagiSugeno,
    /// `zᵢ = μᵢ⁻¹(wᵢ)`.
    Tsukamoto,
}

/// fuzzylite's default resolution of integral defuzzifiers (fuzzylite 6; pyfuzzylite 8 uses
/// 1000, so our FLL files spell the resolution out).
pub const DEFAULT_RESOLUTION: usize = 100;

impl IntegralMethod {
    /// Every method, for error messages.
    pub const ALL: [IntegralMethod; 5] = [
        IntegralMethod::Centroid,
        IntegralMethod::Bisector,
        IntegralMethod::MeanOfMaximum,
        IntegralMethod::SmallestOfMaximum,
        IntegralMethod::LargestOfMaximum,
    ];

    /// fuzzylite's name.
    pub fn name(self) -> &'static str {
        match self {
            IntegralMethod::Centroid => "Centroid",
            IntegralMethod::Bisector => "Bisector",
            IntegralMethod::MeanOfMaximum => "MeanOfMaximum",
            IntegralMethod::SmallestOfMaximum => "SmallestOfMaximum",
            IntegralMethod::LargestOfMaximum => "LargestOfMaximum",
        }
    }

    /// Defuzzifies membership values `ys` sampled at `xs`.
    pub fn defuzzify(self, xs: &[f64], ys: &[f64]) -> f64 {
        match self {
            IntegralMethod::Centroid => centroid(xs, ys),
            IntegralMethod::Bisector => bisector(xs, ys),
            IntegralMethod::MeanOfMaximum => of_maximum(xs, ys, Maximal::Mean),
            IntegralMethod::SmallestOfMaximum => of_maximum(xs, ys, Maximal::Smallest),
            IntegralMethod::LargestOfMaximum => of_maximum(xs, ys, Maximal::Largest),
        }
    }
}

impl WeightedMethod {
    /// fuzzylite's name.
    pub fn name(self) -> &'static str {
        match self {
            WeightedMethod::WeightedAverage => "WeightedAverage",
            WeightedMethod::WeightedSum => "WeightedSum",
        }
    }

    /// Defuzzifies activated terms `(term, degree)`, each term once with its aggregated degree.
    /// `kind` must already be resolved (not `Automatic`).
    pub fn defuzzify<'a>(self, kind: WeightedKind, activated: impl Iterator<Item = (&'a Term, f64)>) -> f64 {
        let mut weighted_sum = 0.0;
        let mut weights = 0.0;
        let mut any = false;
        for (term, w) in activated {
            any = true;
            let z = match kind {
                WeightedKind::Tsukamoto => term.tsukamoto(w),
                WeightedKind::TakagiSugeno | WeightedKind::Automatic => term.membership(w),
            };
            weighted_sum += w * z;
            weights += w;
        }
        if !any {
            return f64::NAN;
        }
        let average = weighted_sum / weights;
        match self {
            WeightedMethod::WeightedAverage => average,
            WeightedMethod::WeightedSum => average * weights,
        }
    }
}

impl WeightedKind {
    /// fuzzylite's name.
    pub fn name(self) -> &'static str {
        match self {
            WeightedKind::Automatic => "Automatic",
            WeightedKind::TakagiSugeno => "TakagiSugeno",
            WeightedKind::Tsukamoto => "Tsukamoto",
        }
    }

    /// The kind named `name`.
    pub fn from_name(name: &str) -> Option<WeightedKind> {
        [WeightedKind::Automatic, WeightedKind::TakagiSugeno, WeightedKind::Tsukamoto]
            .into_iter()
            .find(|kind| kind.name() == name)
    }
}

impl Defuzzifier {
    /// The defuzzifier fuzzylite calls `name`, with default parameters.
    pub fn from_name(name: &str) -> Option<Defuzzifier> {
        if let Some(method) = IntegralMethod::ALL.into_iter().find(|m| m.name() == name) {
            return Some(Defuzzifier::Integral { method, resolution: DEFAULT_RESOLUTION });
        }
        [WeightedMethod::WeightedAverage, WeightedMethod::WeightedSum]
            .into_iter()
            .find(|m| m.name() == name)
            .map(|method| Defuzzifier::Weighted { method, kind: WeightedKind::Automatic })
    }

    /// fuzzylite's name.
    pub fn name(self) -> &'static str {
        match self {
            Defuzzifier::Integral { method, .. } => method.name(),
            Defuzzifier::Weighted { method, .. } => method.name(),
        }
    }
}

/// The `i`-th of `resolution` midpoints of `[min, max]`, computed as numpy does in fuzzylite.
pub fn midpoint(min: f64, max: f64, resolution: usize, i: usize) -> f64 {
    min + (i as f64 + 0.5) * ((max - min) / resolution as f64)
}

fn centroid(xs: &[f64], ys: &[f64]) -> f64 {
    let (moment, area) = xs.iter().zip(ys).fold((0.0, 0.0), |(m, a), (x, y)| (m + x * y, a + y));
    moment / area
}

fn bisector(xs: &[f64], ys: &[f64]) -> f64 {
    let total: f64 = ys.iter().sum();
    // Distance of the cumulative area from one half, at each sample; keep the nearest ones.
    let mut best = f64::INFINITY;
    let mut sum_x = 0.0;
    let mut count = 0usize;
    let mut cumulative = 0.0;
    for (x, y) in xs.iter().zip(ys) {
        cumulative += y;
        let distance = (cumulative / total - 0.5).abs();
        if distance < best {
            best = distance;
            sum_x = *x;
            count = 1;
        } else if distance == best {
            sum_x += x;
            count += 1;
        }
    }
    if count == 0 { f64::NAN } else { sum_x / count as f64 }
}

enum Maximal {
    Mean,
    Smallest,
    Largest,
}

fn of_maximum(xs: &[f64], ys: &[f64], which: Maximal) -> f64 {
    let y_max = ys.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if y_max.is_nan() || y_max <= 0.0 {
        return f64::NAN;
    }
    let mut smallest = f64::NAN;
    let mut largest = f64::NAN;
    let mut sum = 0.0;
    let mut count = 0usize;
    for (x, y) in xs.iter().zip(ys) {
        if *y == y_max {
            if count == 0 {
                smallest = *x;
            }
            largest = *x;
            sum += x;
            count += 1;
        }
    }
    match which {
        Maximal::Mean => sum / count as f64,
        Maximal::Smallest => smallest,
        Maximal::Largest => largest,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn samples(resolution: usize) -> Vec<f64> {
        (0..resolution).map(|i| midpoint(0.0, 1.0, resolution, i)).collect()
    }

    #[test]
    fn integral_methods_on_a_plateau() {
        let xs = samples(10);
        // A plateau of height 1 on the samples 0.25..=0.45 and a lower step after it.
        let ys: Vec<f64> = xs
            .iter()
            .map(|&x| {
                if (0.2..0.5).contains(&x) {
                    1.0
                } else if x > 0.5 {
                    0.5
                } else {
                    0.0
                }
            })
            .collect();
        assert!((IntegralMethod::SmallestOfMaximum.defuzzify(&xs, &ys) - 0.25).abs() < 1e-12);
        assert!((IntegralMethod::LargestOfMaximum.defuzzify(&xs, &ys) - 0.45).abs() < 1e-12);
        assert!((IntegralMethod::MeanOfMaximum.defuzzify(&xs, &ys) - 0.35).abs() < 1e-12);
        let expected = (0.25 + 0.35 + 0.45 + 0.5 * (0.55 + 0.65 + 0.75 + 0.85 + 0.95)) / 5.5;
        assert!((IntegralMethod::Centroid.defuzzify(&xs, &ys) - expected).abs() < 1e-12);
        // Cumulative areas 1, 2, 3, 3.5, … of 5.5: 3 is nearest half (2.75).
        assert!((IntegralMethod::Bisector.defuzzify(&xs, &ys) - 0.45).abs() < 1e-12);
    }

    #[test]
    fn nothing_activated_is_nan() {
        let xs = samples(4);
        let ys = [0.0; 4];
        for method in IntegralMethod::ALL {
            assert!(method.defuzzify(&xs, &ys).is_nan(), "{method:?}");
        }
        let none = std::iter::empty();
        assert!(WeightedMethod::WeightedAverage.defuzzify(WeightedKind::TakagiSugeno, none).is_nan());
    }
}
