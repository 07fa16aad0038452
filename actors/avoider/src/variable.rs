//! Linguistic variables: a named range of values and the terms that describe it.

use crate::defuzzifier::Defuzzifier;
use crate::norms::SNorm;
use crate::term::Term;

/// A variable the rules read.
#[derive(Debug, Clone, PartialEq)]
pub struct InputVariable {
    pub name: String,
    pub min: f64,
    pub max: f64,
    /// A disabled input is ignored by fuzzylite; we refuse rules that read one.
    pub enabled: bool,
    /// Clamp values into `min..=max` before fuzzifying.
    pub lock_range: bool,
    pub terms: Vec<Term>,
}

/// A variable the rules conclude on, turned back into a crisp value by its defuzzifier.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputVariable {
    pub name: String,
    pub min: f64,
    pub max: f64,
    pub enabled: bool,
    /// Clamp the crisp value into `min..=max`.
    pub lock_range: bool,
    /// When no rule activates it: keep the previous crisp value instead of NaN.
    pub lock_previous: bool,
    /// The crisp value when no rule activates it (NaN: none).
    pub default: f64,
    pub defuzzifier: Defuzzifier,
    /// How activated terms combine (fuzzylite's "aggregation", formerly "accumulation").
    pub aggregation: Option<SNorm>,
    pub terms: Vec<Term>,
}

impl InputVariable {
    /// Index of the term called `name`.
    pub fn term_index(&self, name: &str) -> Option<usize> {
        self.terms.iter().position(|t| t.name == name)
    }
}

impl OutputVariable {
    /// Index of the term called `name`.
    pub fn term_index(&self, name: &str) -> Option<usize> {
        self.terms.iter().position(|t| t.name == name)
    }

    /// Width of the range, the scale of agreement and behaviour tolerances.
    pub fn span(&self) -> f64 {
        self.max - self.min
    }
}
