//! A rule base as read from a file, before validation: what each format's parser produces, with
//! the line of every definition so that [`crate::build`] can say where a problem is.

use crate::defuzzifier::Defuzzifier;
use crate::norms::{SNorm, TNorm};
use crate::term::Term;

/// A value and the 1-based line it was defined on.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Located<T> {
    pub(crate) line: usize,
    pub(crate) value: T,
}

#[derive(Debug, Clone, PartialEq, Default)]
pub(crate) struct EngineSpec {
    pub(crate) name: String,
    pub(crate) inputs: Vec<VariableSpec>,
    pub(crate) outputs: Vec<OutputSpec>,
    pub(crate) blocks: Vec<BlockSpec>,
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct VariableSpec {
    pub(crate) line: usize,
    pub(crate) name: String,
    pub(crate) enabled: bool,
    pub(crate) range: Option<Located<(f64, f64)>>,
    pub(crate) lock_range: bool,
    pub(crate) terms: Vec<Located<Term>>,
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct OutputSpec {
    pub(crate) variable: VariableSpec,
    pub(crate) default: f64,
    pub(crate) lock_previous: bool,
    pub(crate) defuzzifier: Option<Defuzzifier>,
    pub(crate) aggregation: Option<SNorm>,
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct BlockSpec {
    pub(crate) line: usize,
    pub(crate) name: String,
    pub(crate) enabled: bool,
    pub(crate) conjunction: Option<TNorm>,
    pub(crate) disjunction: Option<SNorm>,
    pub(crate) implication: Option<TNorm>,
    pub(crate) rules: Vec<Located<String>>,
}

impl VariableSpec {
    /// A variable as fuzzylite defaults it: enabled, no range yet, not locked, no terms.
    pub(crate) fn new(line: usize, name: String) -> Self {
        VariableSpec { line, name, enabled: true, range: None, lock_range: false, terms: Vec::new() }
    }
}

impl OutputSpec {
    pub(crate) fn new(line: usize, name: String) -> Self {
        OutputSpec {
            variable: VariableSpec::new(line, name),
            default: f64::NAN,
            lock_previous: false,
            defuzzifier: None,
            aggregation: None,
        }
    }
}

impl BlockSpec {
    pub(crate) fn new(line: usize, name: String) -> Self {
        BlockSpec {
            line,
            name,
            enabled: true,
            conjunction: None,
            disjunction: None,
            implication: None,
            rules: Vec::new(),
        }
    }
}
