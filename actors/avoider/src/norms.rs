//! T-norms (fuzzy AND, implication) and S-norms (fuzzy OR, aggregation), fuzzylite's names.

/// A triangular norm: conjunction of two degrees, and Mamdani implication.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TNorm {
    /// `min(a, b)` (Zadeh; Mamdani's implication).
    Minimum,
    /// `a · b` (Larsen's implication).
    AlgebraicProduct,
    /// `max(0, a + b − 1)` (Łukasiewicz).
    BoundedDifference,
}

/// A triangular conorm: disjunction of two degrees, and aggregation of activated terms.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SNorm {
    /// `max(a, b)`.
    Maximum,
    /// Probabilistic sum `a + b − a·b`.
    AlgebraicSum,
    /// `min(1, a + b)`.
    BoundedSum,
    /// Plain sum `a + b` (not bounded: fuzzylite's choice for summed aggregation).
    UnboundedSum,
}

impl TNorm {
    /// Every T-norm, for error messages.
    pub const ALL: [TNorm; 3] = [TNorm::Minimum, TNorm::AlgebraicProduct, TNorm::BoundedDifference];

    /// fuzzylite's name.
    pub fn name(self) -> &'static str {
        match self {
            TNorm::Minimum => "Minimum",
            TNorm::AlgebraicProduct => "AlgebraicProduct",
            TNorm::BoundedDifference => "BoundedDifference",
        }
    }

    /// The T-norm fuzzylite calls `name`.
    pub fn from_name(name: &str) -> Option<TNorm> {
        TNorm::ALL.into_iter().find(|norm| norm.name() == name)
    }

    /// Combines two degrees.
    pub fn compute(self, a: f64, b: f64) -> f64 {
        match self {
            TNorm::Minimum => a.min(b),
            TNorm::AlgebraicProduct => a * b,
            TNorm::BoundedDifference => (a + b - 1.0).max(0.0),
        }
    }
}

impl SNorm {
    /// Every S-norm, for error messages.
    pub const ALL: [SNorm; 4] = [SNorm::Maximum, SNorm::AlgebraicSum, SNorm::BoundedSum, SNorm::UnboundedSum];

    /// fuzzylite's name.
    pub fn name(self) -> &'static str {
        match self {
            SNorm::Maximum => "Maximum",
            SNorm::AlgebraicSum => "AlgebraicSum",
            SNorm::BoundedSum => "BoundedSum",
            SNorm::UnboundedSum => "UnboundedSum",
        }
    }

    /// The S-norm fuzzylite calls `name`.
    pub fn from_name(name: &str) -> Option<SNorm> {
        SNorm::ALL.into_iter().find(|norm| norm.name() == name)
    }

    /// Combines two degrees.
    pub fn compute(self, a: f64, b: f64) -> f64 {
        match self {
            SNorm::Maximum => a.max(b),
            SNorm::AlgebraicSum => a + b - a * b,
            SNorm::BoundedSum => (a + b).min(1.0),
            SNorm::UnboundedSum => a + b,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn norms_compute_their_definitions() {
        assert_eq!(TNorm::Minimum.compute(0.3, 0.6), 0.3);
        assert_eq!(TNorm::AlgebraicProduct.compute(0.5, 0.5), 0.25);
        assert_eq!(TNorm::BoundedDifference.compute(0.3, 0.6), 0.0);
        assert_eq!(SNorm::Maximum.compute(0.3, 0.6), 0.6);
        assert_eq!(SNorm::AlgebraicSum.compute(0.5, 0.5), 0.75);
        assert_eq!(SNorm::BoundedSum.compute(0.5, 0.75), 1.0);
        assert_eq!(SNorm::UnboundedSum.compute(0.5, 0.75), 1.25);
        assert_eq!(SNorm::from_name("AlgebraicSum"), Some(SNorm::AlgebraicSum));
        assert_eq!(TNorm::from_name("Maximum"), None);
    }
}
