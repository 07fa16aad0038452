//! One evaluation of a rule base from `NAME=VALUE` text, as `kestrel fuzzy` needs it: the
//! outputs (printable as `NAME=VALUE` lines) and every rule's activation (for logs), both
//! serialisable for `--json`. Allocates; the hot path is [`Engine::infer`].

use std::fmt;

use serde::Serialize;

use crate::engine::{Engine, Workspace};
use crate::error::InputError;

/// The outcome of one evaluation.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Evaluation {
    /// One value per output variable, in the rule base's order (NaN, `null` in JSON, when no
    /// rule activated it and it has no default).
    pub outputs: Vec<NamedValue>,
    /// Every rule's activation degree (weight × antecedent), blocks and rules in order.
    pub rules: Vec<RuleActivation>,
}

/// A variable's crisp value.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NamedValue {
    pub name: String,
    pub value: f64,
}

/// How strongly one rule fired.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RuleActivation {
    pub block: String,
    pub rule: String,
    pub degree: f64,
}

/// Parses `NAME=VALUE` assignments into one value per input of `engine`, in its order. Every
/// input must be given exactly once.
pub fn parse_inputs<S: AsRef<str>>(engine: &Engine, assignments: &[S]) -> Result<Vec<f64>, InputError> {
    let mut values = vec![f64::NAN; engine.inputs().len()];
    let mut given = vec![false; values.len()];
    for assignment in assignments {
        let assignment = assignment.as_ref();
        let (name, value) =
            assignment.split_once('=').ok_or_else(|| InputError::Malformed(assignment.to_string()))?;
        let (name, value) = (name.trim(), value.trim());
        let index = engine.input_index(name).ok_or_else(|| InputError::UnknownVariable(name.to_string()))?;
        if given[index] {
            return Err(InputError::Duplicate(name.to_string()));
        }
        let number: f64 = value
            .parse()
            .map_err(|_| InputError::MalformedNumber { name: name.to_string(), value: value.to_string() })?;
        if number.is_nan() {
            return Err(InputError::NotANumber(name.to_string()));
        }
        values[index] = number;
        given[index] = true;
    }
    if let Some(missing) = given.iter().position(|g| !g) {
        return Err(InputError::Missing(engine.inputs()[missing].name.clone()));
    }
    Ok(values)
}

/// Parses `assignments`, runs the engine once and collects outputs and rule activations.
pub fn evaluate<S: AsRef<str>>(
    engine: &Engine,
    workspace: &mut Workspace,
    assignments: &[S],
) -> Result<Evaluation, InputError> {
    let inputs = parse_inputs(engine, assignments)?;
    let values = engine.infer(workspace, &inputs)?;
    let outputs = engine
        .outputs()
        .iter()
        .zip(values)
        .map(|(v, &value)| NamedValue { name: v.name.clone(), value })
        .collect();
    let rules = engine
        .blocks()
        .iter()
        .flat_map(|b| b.rules.iter().map(move |r| (b, r)))
        .zip(workspace.rule_degrees())
        .map(|((block, rule), &degree)| RuleActivation {
            block: block.name.clone(),
            rule: rule.text.clone(),
            degree,
        })
        .collect();
    Ok(Evaluation { outputs, rules })
}

impl fmt::Display for NamedValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // Debug formatting is the shortest text that reads back to the same f64.
        write!(f, "{}={:?}", self.name, self.value)
    }
}

impl fmt::Display for RuleActivation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:.6} {}", self.degree, self.rule)
    }
}

/// One `NAME=VALUE` line per output variable.
impl fmt::Display for Evaluation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for output in &self.outputs {
            writeln!(f, "{output}")?;
        }
        Ok(())
    }
}
