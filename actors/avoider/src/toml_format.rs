//! Our own TOML format for rule bases: the same content as FLL, in the config language the rest
//! of Kestrel uses, with unknown fields refused so a typo is an error rather than a default.
//!
//! ```toml
//! name = "tipper"
//!
//! [[input]]
//! name = "service"
//! range = [0.0, 10.0]
//! terms = [{ name = "poor", type = "Gaussian", params = [0.0, 1.5] }]
//!
//! [[output]]
//! name = "tip"
//! range = [0.0, 30.0]
//! aggregation = "Maximum"
//! defuzzifier = "Centroid 100"      # as in FLL: NAME [resolution | weighted kind]
//! terms = [{ name = "cheap", type = "Triangle", params = [0.0, 5.0, 10.0] }]
//!
//! [[rule_block]]
//! name = "mamdani"
//! conjunction = "Minimum"
//! implication = "Minimum"
//! rules = ["if service is poor then tip is cheap"]
//! ```
//!
//! Optional fields and their defaults: `enabled = true`, `lock_range = false` (variables);
//! `default = nan`, `lock_previous = false` (outputs); a term's `height = 1.0`; a block's
//! `enabled = true` and absent operators.

use serde::Deserialize;
use toml::Spanned;

use crate::build;
use crate::engine::Engine;
use crate::error::{Cause, LoadError};
use crate::fll;
use crate::spec::{BlockSpec, EngineSpec, Located, OutputSpec, VariableSpec};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    #[serde(default)]
    name: String,
    #[serde(default)]
    input: Vec<Spanned<Input>>,
    #[serde(default)]
    output: Vec<Spanned<Output>>,
    #[serde(default)]
    rule_block: Vec<Spanned<Block>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Input {
    name: String,
    range: Spanned<[f64; 2]>,
    #[serde(default = "yes")]
    enabled: bool,
    #[serde(default)]
    lock_range: bool,
    terms: Vec<Spanned<TermDef>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Output {
    name: String,
    range: Spanned<[f64; 2]>,
    #[serde(default = "yes")]
    enabled: bool,
    #[serde(default)]
    lock_range: bool,
    #[serde(default = "nan")]
    default: f64,
    #[serde(default)]
    lock_previous: bool,
    aggregation: Option<String>,
    defuzzifier: Option<String>,
    terms: Vec<Spanned<TermDef>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TermDef {
    name: String,
    #[serde(rename = "type")]
    kind: String,
    params: Vec<f64>,
    height: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Block {
    #[serde(default)]
    name: String,
    #[serde(default = "yes")]
    enabled: bool,
    conjunction: Option<String>,
    disjunction: Option<String>,
    implication: Option<String>,
    activation: Option<String>,
    rules: Vec<Spanned<String>>,
}

fn yes() -> bool {
    true
}

fn nan() -> f64 {
    f64::NAN
}

/// Parses TOML `text`; `origin` names it in errors (usually the file's path).
pub fn parse(text: &str, origin: &str) -> Result<Engine, LoadError> {
    let fail = |line: usize, cause: Cause| LoadError::Invalid { origin: origin.to_string(), line, cause };
    let line_of = |offset: usize| {
        let before = &text.as_bytes()[..offset.min(text.len())];
        before.iter().filter(|&&b| b == b'\n').count() + 1
    };
    let file: File = toml::from_str(text).map_err(|e| {
        let line = e.span().map_or(0, |s| line_of(s.start));
        fail(line, Cause::Syntax(e.message().to_string()))
    })?;
    let spec = to_spec(file, &line_of).map_err(|(line, cause)| fail(line, cause))?;
    build::engine(spec, origin)
}

fn to_spec(file: File, line_of: &dyn Fn(usize) -> usize) -> Result<EngineSpec, (usize, Cause)> {
    let variable = |line: usize,
                    name: String,
                    range: Spanned<[f64; 2]>,
                    enabled: bool,
                    lock_range: bool,
                    terms: Vec<Spanned<TermDef>>|
     -> Result<VariableSpec, (usize, Cause)> {
        let range_line = line_of(range.span().start);
        let [min, max] = range.into_inner();
        let terms = terms
            .into_iter()
            .map(|t| {
                let line = line_of(t.span().start);
                let t = t.into_inner();
                let mut params = t.params;
                params.extend(t.height);
                build::term(&t.name, &t.kind, &params)
                    .map(|value| Located { line, value })
                    .map_err(|c| (line, c))
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(VariableSpec {
            line,
            name,
            enabled,
            range: Some(Located { line: range_line, value: (min, max) }),
            lock_range,
            terms,
        })
    };
    let mut spec = EngineSpec { name: file.name, ..EngineSpec::default() };
    for input in file.input {
        let line = line_of(input.span().start);
        let i = input.into_inner();
        spec.inputs.push(variable(line, i.name, i.range, i.enabled, i.lock_range, i.terms)?);
    }
    for output in file.output {
        let line = line_of(output.span().start);
        let o = output.into_inner();
        let at = |c| (line, c);
        let mut spec_output = OutputSpec::new(line, o.name.clone());
        spec_output.variable = variable(line, o.name, o.range, o.enabled, o.lock_range, o.terms)?;
        spec_output.default = o.default;
        spec_output.lock_previous = o.lock_previous;
        spec_output.aggregation = o.aggregation.as_deref().map(fll::snorm).transpose().map_err(at)?;
        spec_output.defuzzifier = o.defuzzifier.as_deref().map(fll::defuzzifier).transpose().map_err(at)?;
        spec.outputs.push(spec_output);
    }
    for block in file.rule_block {
        let line = line_of(block.span().start);
        let b = block.into_inner();
        let at = |c| (line, c);
        if let Some(activation) = b.activation.as_deref()
            && activation != "General"
        {
            return Err(at(Cause::UnknownName {
                what: "activation method",
                name: activation.into(),
                expected: "General".into(),
            }));
        }
        let mut spec_block = BlockSpec::new(line, b.name);
        spec_block.enabled = b.enabled;
        spec_block.conjunction = b.conjunction.as_deref().map(fll::tnorm).transpose().map_err(at)?;
        spec_block.disjunction = b.disjunction.as_deref().map(fll::snorm).transpose().map_err(at)?;
        spec_block.implication = b.implication.as_deref().map(fll::tnorm).transpose().map_err(at)?;
        spec_block.rules = b
            .rules
            .into_iter()
            .map(|r| Located { line: line_of(r.span().start), value: r.into_inner() })
            .collect();
        spec.blocks.push(spec_block);
    }
    Ok(spec)
}
