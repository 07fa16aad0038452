//! fuzzylite's FLL text format, the format fuzzylite and QtFuzzyLite users already have:
//!
//! ```text
//! Engine: tipper
//! InputVariable: service
//!   enabled: true
//!   range: 0.000 10.000
//!   lock-range: false
//!   term: poor Gaussian 0.000 1.500
//! OutputVariable: tip
//!   range: 0 30
//!   default: nan
//!   lock-previous: false
//!   aggregation: Maximum          # "accumulation" in fuzzylite 5
//!   defuzzifier: Centroid 100
//!   term: cheap Triangle 0 5 10
//! RuleBlock: mamdani
//!   conjunction: Minimum
//!   disjunction: Maximum
//!   implication: Minimum
//!   activation: General
//!   rule: if service is poor then tip is cheap
//! ```
//!
//! Each line is `key: value`; `#` starts a comment. The parser only reads; every check of
//! meaning is in the crate's private `build` module.

use crate::build;
use crate::defuzzifier::{Defuzzifier, IntegralMethod, WeightedKind};
use crate::engine::Engine;
use crate::error::{Cause, LoadError};
use crate::norms::{SNorm, TNorm};
use crate::spec::{BlockSpec, EngineSpec, Located, OutputSpec, VariableSpec};

/// Parses FLL `text`; `origin` names it in errors (usually the file's path).
pub fn parse(text: &str, origin: &str) -> Result<Engine, LoadError> {
    let spec =
        read(text).map_err(|(line, cause)| LoadError::Invalid { origin: origin.to_string(), line, cause })?;
    build::engine(spec, origin)
}

enum Section {
    None,
    Engine,
    Input,
    Output,
    Block,
}

fn read(text: &str) -> Result<EngineSpec, (usize, Cause)> {
    let mut spec = EngineSpec::default();
    let mut section = Section::None;
    for (index, raw) in text.lines().enumerate() {
        let line = index + 1;
        let content = raw.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        let (key, value) = content
            .split_once(':')
            .ok_or_else(|| (line, Cause::Syntax(format!("expected 'key: value', found '{content}'"))))?;
        let (key, value) = (key.trim(), value.trim());
        let at = |cause| (line, cause);
        match key {
            "Engine" => {
                spec.name = value.to_string();
                section = Section::Engine;
                continue;
            }
            "InputVariable" => {
                spec.inputs.push(VariableSpec::new(line, name(value, line)?));
                section = Section::Input;
                continue;
            }
            "OutputVariable" => {
                spec.outputs.push(OutputSpec::new(line, name(value, line)?));
                section = Section::Output;
                continue;
            }
            "RuleBlock" => {
                spec.blocks.push(BlockSpec::new(line, value.to_string()));
                section = Section::Block;
                continue;
            }
            _ => {}
        }
        match section {
            Section::Engine if key == "description" => {}
            Section::Input | Section::Output if key == "description" => {}
            Section::Input => {
                let variable = spec.inputs.last_mut().ok_or_else(|| at(orphan(key)))?;
                variable_key(variable, key, value, line)?;
            }
            Section::Output => {
                let output = spec.outputs.last_mut().ok_or_else(|| at(orphan(key)))?;
                match key {
                    "default" => output.default = number(value).map_err(at)?,
                    "lock-previous" | "lock-valid" => {
                        output.lock_previous = boolean(value).map_err(at)?;
                    }
                    "aggregation" | "accumulation" => {
                        output.aggregation = optional(value, snorm).map_err(at)?;
                    }
                    "defuzzifier" => {
                        output.defuzzifier = optional(value, defuzzifier).map_err(at)?;
                    }
                    _ => variable_key(&mut output.variable, key, value, line)?,
                }
            }
            Section::Block => {
                let block = spec.blocks.last_mut().ok_or_else(|| at(orphan(key)))?;
                match key {
                    "description" => {}
                    "enabled" => block.enabled = boolean(value).map_err(at)?,
                    "conjunction" => block.conjunction = optional(value, tnorm).map_err(at)?,
                    "disjunction" => block.disjunction = optional(value, snorm).map_err(at)?,
                    "implication" => block.implication = optional(value, tnorm).map_err(at)?,
                    "activation" => {
                        if value != "General" && value != "none" && !value.is_empty() {
                            return Err(at(Cause::UnknownName {
                                what: "activation method",
                                name: value.into(),
                                expected: "General".into(),
                            }));
                        }
                    }
                    "rule" => block.rules.push(Located { line, value: value.to_string() }),
                    _ => return Err(at(unknown_key(key, "RuleBlock"))),
                }
            }
            Section::Engine => return Err(at(unknown_key(key, "Engine"))),
            Section::None => return Err(at(orphan(key))),
        }
    }
    Ok(spec)
}

fn variable_key(
    variable: &mut VariableSpec,
    key: &str,
    value: &str,
    line: usize,
) -> Result<(), (usize, Cause)> {
    let at = |cause| (line, cause);
    match key {
        "enabled" => variable.enabled = boolean(value).map_err(at)?,
        "lock-range" => variable.lock_range = boolean(value).map_err(at)?,
        "range" => {
            let values = numbers(value).map_err(at)?;
            let [min, max] = values[..] else {
                return Err(at(Cause::Syntax(format!("expected 'range: MIN MAX', found '{value}'"))));
            };
            variable.range = Some(Located { line, value: (min, max) });
        }
        "term" => {
            let mut words = value.split_whitespace();
            let (Some(term_name), Some(kind)) = (words.next(), words.next()) else {
                return Err(at(Cause::Syntax(format!(
                    "expected 'term: NAME TYPE PARAMETERS…', found '{value}'"
                ))));
            };
            let params = words.map(number).collect::<Result<Vec<_>, _>>().map_err(at)?;
            let term = build::term(term_name, kind, &params).map_err(at)?;
            variable.terms.push(Located { line, value: term });
        }
        _ => return Err(at(unknown_key(key, "a variable"))),
    }
    Ok(())
}

fn name(value: &str, line: usize) -> Result<String, (usize, Cause)> {
    let valid = !value.is_empty() && value.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '.');
    if valid {
        Ok(value.to_string())
    } else {
        Err((line, Cause::Syntax(format!("'{value}' is not a valid variable name"))))
    }
}

fn orphan(key: &str) -> Cause {
    Cause::Syntax(format!("'{key}' outside of any section"))
}

fn unknown_key(key: &str, section: &str) -> Cause {
    Cause::Syntax(format!("'{key}' is not a property of {section}"))
}

fn number(text: &str) -> Result<f64, Cause> {
    text.parse().map_err(|_| Cause::MalformedNumber(text.to_string()))
}

fn numbers(text: &str) -> Result<Vec<f64>, Cause> {
    text.split_whitespace().map(number).collect()
}

fn boolean(text: &str) -> Result<bool, Cause> {
    match text {
        "true" => Ok(true),
        "false" => Ok(false),
        _ => Err(Cause::Syntax(format!("expected true or false, found '{text}'"))),
    }
}

fn optional<T>(value: &str, parse: fn(&str) -> Result<T, Cause>) -> Result<Option<T>, Cause> {
    if value.is_empty() || value == "none" { Ok(None) } else { parse(value).map(Some) }
}

fn names<T: Copy>(all: &[T], name: fn(T) -> &'static str) -> String {
    all.iter().map(|t| name(*t)).collect::<Vec<_>>().join(", ")
}

pub(crate) fn tnorm(value: &str) -> Result<TNorm, Cause> {
    TNorm::from_name(value).ok_or_else(|| Cause::UnknownName {
        what: "T-norm",
        name: value.into(),
        expected: names(&TNorm::ALL, TNorm::name),
    })
}

pub(crate) fn snorm(value: &str) -> Result<SNorm, Cause> {
    SNorm::from_name(value).ok_or_else(|| Cause::UnknownName {
        what: "S-norm",
        name: value.into(),
        expected: names(&SNorm::ALL, SNorm::name),
    })
}

/// `NAME [PARAMETER]`: a resolution for integral defuzzifiers, a kind for weighted ones.
pub(crate) fn defuzzifier(value: &str) -> Result<Defuzzifier, Cause> {
    let mut words = value.split_whitespace();
    let name = words.next().unwrap_or("");
    let parameter = words.next();
    if let Some(extra) = words.next() {
        return Err(Cause::Syntax(format!("unexpected '{extra}' after the defuzzifier")));
    }
    let defuzzifier = Defuzzifier::from_name(name).ok_or_else(|| Cause::UnknownName {
        what: "defuzzifier",
        name: name.into(),
        expected: format!(
            "{}, WeightedAverage, WeightedSum",
            names(&IntegralMethod::ALL, IntegralMethod::name)
        ),
    })?;
    Ok(match (defuzzifier, parameter) {
        (d, None) => d,
        (Defuzzifier::Integral { method, .. }, Some(p)) => {
            Defuzzifier::Integral { method, resolution: resolution(p)? }
        }
        (Defuzzifier::Weighted { method, .. }, Some(p)) => {
            Defuzzifier::Weighted { method, kind: weighted_kind(p)? }
        }
    })
}

/// The most samples an integral defuzzifier may take: a hundred times fuzzylite's default of
/// 1000; each output variable keeps this many samples per term.
pub const MAX_RESOLUTION: usize = 100_000;

/// A resolution: a whole number of samples in `1..=MAX_RESOLUTION`. fuzzylite reads any
/// integer here, but with 0 or fewer samples every output it computes is NaN, so a resolution
/// below 1 is refused as what it is, not as a malformed number.
pub(crate) fn resolution(text: &str) -> Result<usize, Cause> {
    let n: i128 = text.parse().map_err(|_| Cause::MalformedNumber(text.to_string()))?;
    match usize::try_from(n) {
        Ok(n) if (1..=MAX_RESOLUTION).contains(&n) => Ok(n),
        _ => Err(Cause::Resolution { found: text.to_string(), max: MAX_RESOLUTION }),
    }
}

pub(crate) fn weighted_kind(text: &str) -> Result<WeightedKind, Cause> {
    WeightedKind::from_name(text).ok_or_else(|| Cause::UnknownName {
        what: "weighted defuzzifier type",
        name: text.into(),
        expected: "Automatic, TakagiSugeno, Tsukamoto".into(),
    })
}
