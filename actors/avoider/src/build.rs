//! Validation: from what a file said ([`EngineSpec`]) to an [`Engine`] that can run, or an error
//! naming the line and the cause. Both file formats go through here, so they reject the same
//! things in the same words.

use crate::defuzzifier::{Defuzzifier, WeightedKind};
use crate::engine::{Engine, RuleBlock, SampledOutput};
use crate::error::{Cause, LoadError};
use crate::hedge::Hedge;
use crate::rule::{self, Rule};
use crate::spec::{EngineSpec, Located, VariableSpec};
use crate::term::{Shape, ShapeKind, Term};
use crate::variable::{InputVariable, OutputVariable};

/// Samples per input range when checking that a proposition can ever be true.
const REACHABILITY_SAMPLES: usize = 1000;

/// Makes a term of fuzzylite type `kind` from its parameters (with an optional trailing height).
pub(crate) fn term(name: &str, kind: &str, params: &[f64]) -> Result<Term, Cause> {
    let kind = ShapeKind::from_name(kind).ok_or_else(|| Cause::UnknownTermType(kind.into()))?;
    let n = kind.parameter_count();
    let (shape_params, height) = match params.len() {
        len if len == n => (params, 1.0),
        len if len == n + 1 && kind.takes_height() => (&params[..n], params[n]),
        got => {
            return Err(Cause::ParameterCount {
                term: name.into(),
                kind: kind.name(),
                expected: if kind.takes_height() {
                    format!("{n} (or {} with a height)", n + 1)
                } else {
                    n.to_string()
                },
                got,
            });
        }
    };
    let invalid = |reason: &str| Cause::InvalidTerm { term: name.into(), reason: reason.into() };
    if !height.is_finite() || !(0.0..=1.0).contains(&height) {
        return Err(invalid("height must be within 0..1"));
    }
    let vertices_ok = shape_params.iter().all(|p| !p.is_nan());
    let finite = shape_params.iter().all(|p| p.is_finite());
    let p = shape_params;
    let shape = match kind {
        ShapeKind::Triangle | ShapeKind::Trapezoid if !vertices_ok => {
            return Err(invalid("vertices must be numbers"));
        }
        ShapeKind::Triangle => {
            if !(p[0] <= p[1] && p[1] <= p[2]) {
                return Err(invalid("vertices must be in order: left ≤ top ≤ right"));
            }
            Shape::Triangle { left: p[0], top: p[1], right: p[2] }
        }
        ShapeKind::Trapezoid => {
            if !(p[0] <= p[1] && p[1] <= p[2] && p[2] <= p[3]) {
                return Err(invalid("vertices must be in order: a ≤ b ≤ c ≤ d"));
            }
            Shape::Trapezoid { bottom_left: p[0], top_left: p[1], top_right: p[2], bottom_right: p[3] }
        }
        _ if !finite => return Err(invalid("parameters must be finite")),
        ShapeKind::Gaussian => {
            if p[1] <= 0.0 {
                return Err(invalid("standard deviation must be positive"));
            }
            Shape::Gaussian { mean: p[0], sd: p[1] }
        }
        ShapeKind::Bell => {
            if p[1] == 0.0 {
                return Err(invalid("width must not be zero"));
            }
            Shape::Bell { center: p[0], width: p[1], slope: p[2] }
        }
        ShapeKind::Sigmoid => Shape::Sigmoid { inflection: p[0], slope: p[1] },
        ShapeKind::Ramp => {
            if p[0] == p[1] {
                return Err(invalid("start and end must differ"));
            }
            Shape::Ramp { start: p[0], end: p[1] }
        }
        ShapeKind::Constant => Shape::Constant { value: p[0] },
    };
    Ok(Term { name: name.into(), shape, height })
}

/// Validates `spec` (read from `origin`) into an engine.
pub(crate) fn engine(spec: EngineSpec, origin: &str) -> Result<Engine, LoadError> {
    let fail = |line: usize, cause: Cause| LoadError::Invalid { origin: origin.to_string(), line, cause };
    if spec.inputs.is_empty() {
        return Err(fail(0, Cause::Empty("input variables")));
    }
    if spec.outputs.is_empty() {
        return Err(fail(0, Cause::Empty("output variables")));
    }
    if spec.blocks.iter().all(|b| b.rules.is_empty()) {
        return Err(fail(0, Cause::Empty("rules")));
    }
    let mut names: Vec<&str> = Vec::new();
    let all_variables = spec.inputs.iter().chain(spec.outputs.iter().map(|o| &o.variable));
    for variable in all_variables {
        if names.contains(&variable.name.as_str()) {
            return Err(fail(variable.line, Cause::Duplicate(variable.name.clone())));
        }
        names.push(&variable.name);
    }

    let inputs = spec
        .inputs
        .iter()
        .map(|v| {
            let (min, max, terms) = checked_variable(v).map_err(|(l, c)| fail(l, c))?;
            Ok(InputVariable {
                name: v.name.clone(),
                min,
                max,
                enabled: v.enabled,
                lock_range: v.lock_range,
                terms,
            })
        })
        .collect::<Result<Vec<_>, LoadError>>()?;
    let outputs = spec
        .outputs
        .iter()
        .map(|o| {
            let v = &o.variable;
            let (min, max, terms) = checked_variable(v).map_err(|(l, c)| fail(l, c))?;
            let defuzzifier =
                o.defuzzifier.ok_or_else(|| fail(v.line, Cause::MissingDefuzzifier(v.name.clone())))?;
            if matches!(defuzzifier, Defuzzifier::Integral { .. }) && o.aggregation.is_none() {
                return Err(fail(v.line, Cause::MissingAggregation(v.name.clone())));
            }
            Ok(OutputVariable {
                name: v.name.clone(),
                min,
                max,
                enabled: v.enabled,
                lock_range: v.lock_range,
                lock_previous: o.lock_previous,
                default: o.default,
                defuzzifier,
                aggregation: o.aggregation,
                terms,
            })
        })
        .collect::<Result<Vec<_>, LoadError>>()?;

    let mut blocks = Vec::with_capacity(spec.blocks.len());
    for block in &spec.blocks {
        let mut rules = Vec::with_capacity(block.rules.len());
        for Located { line, value: text } in &block.rules {
            let rule = rule::parse(text, &inputs, &outputs).map_err(|c| fail(*line, c))?;
            check_operators(block, &rule, &outputs).map_err(|c| fail(*line, c))?;
            check_can_fire(&rule, &inputs, &outputs, block).map_err(|c| fail(*line, c))?;
            rules.push(rule);
        }
        blocks.push(RuleBlock {
            name: block.name.clone(),
            enabled: block.enabled,
            conjunction: block.conjunction,
            disjunction: block.disjunction,
            implication: block.implication,
            rules,
        });
    }

    let mut sampled = Vec::with_capacity(outputs.len());
    for (index, (output, o_spec)) in outputs.iter().zip(&spec.outputs).enumerate() {
        let concluded =
            blocks.iter().flat_map(|b| &b.rules).flat_map(|r| &r.conclusions).filter(|c| c.variable == index);
        let conclusions = concluded.clone().count();
        let kinds: Vec<ShapeKind> = concluded.map(|c| output.terms[c.term].kind()).collect();
        let kind = weighted_kind(output, &kinds).map_err(|reason| fail(o_spec.variable.line, reason))?;
        sampled.push(SampledOutput::new(output, kind, conclusions));
    }

    let offsets = |lengths: &mut dyn Iterator<Item = usize>| -> Vec<usize> {
        lengths
            .scan(0, |acc, len| {
                let start = *acc;
                *acc += len;
                Some(start)
            })
            .collect()
    };
    let input_offsets = offsets(&mut inputs.iter().map(|v| v.terms.len()));
    let rule_offsets = offsets(&mut blocks.iter().map(|b| b.rules.len()));
    Ok(Engine { name: spec.name, inputs, outputs, blocks, sampled, input_offsets, rule_offsets })
}

type LineCause = (usize, Cause);

/// The variable's range and terms, checked: a valid range, unique term names, every term
/// peaking inside the range.
fn checked_variable(v: &VariableSpec) -> Result<(f64, f64, Vec<Term>), LineCause> {
    let range = v.range.as_ref().ok_or((v.line, Cause::MissingRange(v.name.clone())))?;
    let (min, max) = range.value;
    if !(min.is_finite() && max.is_finite() && min < max) {
        return Err((range.line, Cause::InvalidRange { variable: v.name.clone(), min, max }));
    }
    let mut terms: Vec<Term> = Vec::with_capacity(v.terms.len());
    for Located { line, value: term } in &v.terms {
        if terms.iter().any(|t| t.name == term.name) {
            return Err((*line, Cause::Duplicate(format!("{}.{}", v.name, term.name))));
        }
        let (lo, hi) = term.peak();
        if hi < min || lo > max {
            return Err((
                *line,
                Cause::TermOutsideRange {
                    variable: v.name.clone(),
                    term: term.name.clone(),
                    peak_lo: lo,
                    peak_hi: hi,
                    min,
                    max,
                },
            ));
        }
        terms.push(term.clone());
    }
    if terms.is_empty() {
        return Err((v.line, Cause::Empty("terms in a variable")));
    }
    Ok((min, max, terms))
}

/// The block has every operator the rule needs.
fn check_operators(
    block: &crate::spec::BlockSpec,
    rule: &Rule,
    outputs: &[OutputVariable],
) -> Result<(), Cause> {
    let missing = |what| Cause::MissingNorm { block: block.name.clone(), what, rule: rule.text.clone() };
    let (and, or) = rule.antecedent.uses();
    if and && block.conjunction.is_none() {
        return Err(missing("a conjunction"));
    }
    if or && block.disjunction.is_none() {
        return Err(missing("a disjunction"));
    }
    let integral = rule
        .conclusions
        .iter()
        .any(|c| matches!(outputs[c.variable].defuzzifier, Defuzzifier::Integral { .. }));
    if integral && block.implication.is_none() {
        return Err(missing("an implication"));
    }
    Ok(())
}

/// Refuses rules that cannot contribute: reading a disabled input, concluding only on disabled
/// outputs, weight zero, or an antecedent that is zero over the whole input range.
fn check_can_fire(
    rule: &Rule,
    inputs: &[InputVariable],
    outputs: &[OutputVariable],
    block: &crate::spec::BlockSpec,
) -> Result<(), Cause> {
    let never = |reason: String| Cause::NeverFires { rule: rule.text.clone(), reason };
    let mut propositions = Vec::new();
    rule.antecedent.propositions(&mut propositions);
    if let Some(p) = propositions.iter().find(|p| !inputs[p.variable].enabled) {
        return Err(never(format!("input variable '{}' is disabled", inputs[p.variable].name)));
    }
    if let Some(c) = rule.conclusions.iter().find(|c| !outputs[c.variable].enabled) {
        return Err(never(format!("output variable '{}' is disabled", outputs[c.variable].name)));
    }
    if rule.weight <= 0.0 {
        return Err(never("its weight is zero".into()));
    }
    let and = block.conjunction.unwrap_or(crate::norms::TNorm::Minimum);
    let or = block.disjunction.unwrap_or(crate::norms::SNorm::Maximum);
    let mut dead = None;
    let bound = rule.antecedent.fold(
        &mut |p| {
            let best = highest_membership(&inputs[p.variable], p.term, &p.hedges);
            if best <= 0.0 && dead.is_none() {
                dead = Some(p.clone());
            }
            best
        },
        &|a, b| and.compute(a, b),
        &|a, b| or.compute(a, b),
    );
    if bound <= 0.0 {
        let reason = match dead {
            Some(p) => {
                let input = &inputs[p.variable];
                format!(
                    "'{} is {}' is zero over the whole range {}..{}",
                    input.name, input.terms[p.term].name, input.min, input.max
                )
            }
            None => "its antecedent is zero over the whole input range".into(),
        };
        return Err(never(reason));
    }
    Ok(())
}

/// The largest hedged membership of `term` over the variable's range (sampled, plus the
/// term's own peak, so narrow terms are not missed).
fn highest_membership(input: &InputVariable, term: usize, hedges: &[Hedge]) -> f64 {
    let term = &input.terms[term];
    let (lo, hi) = term.peak();
    let (min, max) = (input.min, input.max);
    let step = (max - min) / REACHABILITY_SAMPLES as f64;
    (0..=REACHABILITY_SAMPLES)
        .map(|i| min + i as f64 * step)
        .chain([lo.clamp(min, max), hi.clamp(min, max)])
        .map(|x| Hedge::apply_all(hedges, term.membership(x)))
        .fold(0.0, f64::max)
}

/// Resolves a weighted defuzzifier's kind from the kinds of the terms rules conclude on, as
/// fuzzylite infers it at run time (we refuse at load what it would refuse then).
fn weighted_kind(output: &OutputVariable, kinds: &[ShapeKind]) -> Result<WeightedKind, Cause> {
    let Defuzzifier::Weighted { kind, .. } = output.defuzzifier else {
        return Ok(WeightedKind::Automatic);
    };
    let classify = |k: &ShapeKind| match k {
        ShapeKind::Constant => WeightedKind::TakagiSugeno,
        ShapeKind::Ramp | ShapeKind::Sigmoid => WeightedKind::Tsukamoto,
        _ => WeightedKind::Automatic,
    };
    let fail = |reason: &str| Cause::WeightedKind { variable: output.name.clone(), reason: reason.into() };
    match kind {
        WeightedKind::Automatic => {
            let mut classes = kinds.iter().map(classify);
            let first = classes.next().unwrap_or(WeightedKind::Automatic);
            if classes.any(|c| c != first) {
                return Err(fail(
                    "its terms mix constant, monotonic and other shapes, so the weighted \
                     defuzzifier's kind cannot be inferred",
                ));
            }
            Ok(first)
        }
        WeightedKind::Tsukamoto => {
            if kinds.iter().any(|k| classify(k) != WeightedKind::Tsukamoto) {
                return Err(fail("Tsukamoto needs monotonic terms (Ramp, Sigmoid)"));
            }
            Ok(kind)
        }
        WeightedKind::TakagiSugeno => Ok(kind),
    }
}
