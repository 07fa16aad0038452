//! Mamdani inference: fuzzify the inputs, activate the rules, aggregate, defuzzify.
//!
//! [`Engine`] is the immutable rule base, validated and ready to run; [`Workspace`] holds every
//! buffer one inference needs, sized when it is made, so [`Engine::infer`] never allocates and
//! one engine can serve several threads, each with its own workspace.
//!
//! Two things make an inference cheap without changing its result:
//! * each output term's membership at the defuzzifier's sample points is tabulated once, when
//!   the engine is built (the sample points never change);
//! * with `Maximum` aggregation, activations of the same term under the same implication are
//!   merged first (`max(I(a, μ), I(b, μ)) = I(max(a, b), μ)` for monotone implications).

use crate::defuzzifier::{Defuzzifier, WeightedKind, midpoint};
use crate::error::InputError;
use crate::hedge::Hedge;
use crate::norms::{SNorm, TNorm};
use crate::rule::Rule;
use crate::variable::{InputVariable, OutputVariable};

/// A group of rules sharing its operators.
#[derive(Debug, Clone, PartialEq)]
pub struct RuleBlock {
    pub name: String,
    pub enabled: bool,
    pub conjunction: Option<TNorm>,
    pub disjunction: Option<SNorm>,
    pub implication: Option<TNorm>,
    pub rules: Vec<Rule>,
}

/// A validated rule base, ready for inference.
#[derive(Debug, Clone)]
pub struct Engine {
    pub(crate) name: String,
    pub(crate) inputs: Vec<InputVariable>,
    pub(crate) outputs: Vec<OutputVariable>,
    pub(crate) blocks: Vec<RuleBlock>,
    /// Per output: the tables and resolved defuzzifier kind used at inference.
    pub(crate) sampled: Vec<SampledOutput>,
    /// Offset of each input's terms in the workspace's fuzzified values.
    pub(crate) input_offsets: Vec<usize>,
    /// Offset of each block's rules in the workspace's rule degrees.
    pub(crate) rule_offsets: Vec<usize>,
}

/// What inference needs to know of one output variable beyond its definition.
#[derive(Debug, Clone)]
pub(crate) struct SampledOutput {
    /// Defuzzifier sample points (integral defuzzifiers; empty otherwise).
    pub(crate) xs: Vec<f64>,
    /// `μ_t(xs[i])` at `t * xs.len() + i`.
    pub(crate) table: Vec<f64>,
    /// The weighted defuzzifier's kind, `Automatic` resolved from the terms.
    pub(crate) kind: WeightedKind,
    /// How many conclusions across all rules name this output.
    pub(crate) conclusions: usize,
}

/// One activated term of an output: the rule's degree after the conclusion's hedges.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Activation {
    term: usize,
    degree: f64,
    implication: Option<TNorm>,
}

/// Scratch buffers of one inference, reusable across inferences of the same engine.
#[derive(Debug, Clone)]
pub struct Workspace {
    /// The (range-locked) input values of the last inference.
    inputs: Vec<f64>,
    /// Membership of each input value in each of its variable's terms.
    fuzzified: Vec<f64>,
    /// Activation degree of each rule (weight × antecedent), blocks in order.
    rule_degrees: Vec<f64>,
    /// Per output, the activated terms.
    activated: Vec<Vec<Activation>>,
    /// Per output, aggregated membership at the sample points.
    aggregated: Vec<Vec<f64>>,
    /// Per output, degree per term for weighted defuzzifiers (NaN: not activated).
    grouped: Vec<Vec<f64>>,
    outputs: Vec<f64>,
    /// Per output, the last crisp value (for `lock-previous`).
    previous: Vec<f64>,
}

impl Engine {
    /// The rule base's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The input variables, in the order [`Engine::infer`] takes their values.
    pub fn inputs(&self) -> &[InputVariable] {
        &self.inputs
    }

    /// The output variables, in the order [`Engine::infer`] returns their values.
    pub fn outputs(&self) -> &[OutputVariable] {
        &self.outputs
    }

    /// The rule blocks.
    pub fn blocks(&self) -> &[RuleBlock] {
        &self.blocks
    }

    /// Index of the input called `name`.
    pub fn input_index(&self, name: &str) -> Option<usize> {
        self.inputs.iter().position(|v| v.name == name)
    }

    /// Index of the output called `name`.
    pub fn output_index(&self, name: &str) -> Option<usize> {
        self.outputs.iter().position(|v| v.name == name)
    }

    /// A workspace sized for this engine.
    pub fn workspace(&self) -> Workspace {
        let rules = self.blocks.iter().map(|b| b.rules.len()).sum();
        Workspace {
            inputs: vec![f64::NAN; self.inputs.len()],
            fuzzified: vec![0.0; self.inputs.iter().map(|v| v.terms.len()).sum()],
            rule_degrees: vec![0.0; rules],
            activated: self.sampled.iter().map(|s| Vec::with_capacity(s.conclusions)).collect(),
            aggregated: self.sampled.iter().map(|s| vec![0.0; s.xs.len()]).collect(),
            grouped: self.outputs.iter().map(|v| vec![f64::NAN; v.terms.len()]).collect(),
            outputs: vec![f64::NAN; self.outputs.len()],
            previous: vec![f64::NAN; self.outputs.len()],
        }
    }

    /// Evaluates the rule base on `inputs` (one value per input variable, in order) and returns
    /// one crisp value per output variable, in order. An output no rule activates is NaN
    /// unless its variable has a default or locks the previous value. A disabled output is NaN.
    ///
    /// `workspace` must come from [`Engine::workspace`] of this engine (a workspace of another
    /// rule base is refused, never indexed out of bounds).
    pub fn infer<'w>(&self, workspace: &'w mut Workspace, inputs: &[f64]) -> Result<&'w [f64], InputError> {
        if inputs.len() != self.inputs.len() {
            return Err(InputError::Count { expected: self.inputs.len(), got: inputs.len() });
        }
        if !self.fits(workspace) {
            return Err(InputError::ForeignWorkspace);
        }
        if let Some(bad) = inputs.iter().position(|x| x.is_nan()) {
            return Err(InputError::NotANumber(self.inputs[bad].name.clone()));
        }
        self.fuzzify(workspace, inputs);
        self.activate(workspace);
        self.defuzzify(workspace);
        Ok(&workspace.outputs)
    }

    /// Whether `ws` was made by [`Engine::workspace`] of an engine shaped like this one.
    fn fits(&self, ws: &Workspace) -> bool {
        ws.inputs.len() == self.inputs.len()
            && ws.fuzzified.len() == self.inputs.iter().map(|v| v.terms.len()).sum::<usize>()
            && ws.rule_degrees.len() == self.blocks.iter().map(|b| b.rules.len()).sum::<usize>()
            && ws.outputs.len() == self.outputs.len()
            && ws.activated.len() == self.outputs.len()
            && self.sampled.iter().zip(&ws.aggregated).all(|(s, ys)| s.xs.len() == ys.len())
            && self.outputs.iter().zip(&ws.grouped).all(|(v, g)| v.terms.len() == g.len())
    }

    fn fuzzify(&self, ws: &mut Workspace, inputs: &[f64]) {
        for ((variable, &x), (slot, &offset)) in
            self.inputs.iter().zip(inputs).zip(ws.inputs.iter_mut().zip(&self.input_offsets))
        {
            let x = if variable.lock_range { x.clamp(variable.min, variable.max) } else { x };
            *slot = x;
            for (term, mu) in variable.terms.iter().zip(&mut ws.fuzzified[offset..]) {
                *mu = term.membership(x);
            }
        }
    }

    fn activate(&self, ws: &mut Workspace) {
        for activated in &mut ws.activated {
            activated.clear();
        }
        for (block, &offset) in self.blocks.iter().zip(&self.rule_offsets) {
            let degrees = &mut ws.rule_degrees[offset..offset + block.rules.len()];
            if !block.enabled {
                degrees.fill(0.0);
                continue;
            }
            // Operators a rule needs were checked at load; the fallbacks are never used.
            let and = block.conjunction.unwrap_or(TNorm::Minimum);
            let or = block.disjunction.unwrap_or(SNorm::Maximum);
            for (rule, degree) in block.rules.iter().zip(degrees.iter_mut()) {
                let mut leaf = |p: &crate::rule::Proposition| {
                    let mu = ws.fuzzified[self.input_offsets[p.variable] + p.term];
                    Hedge::apply_all(&p.hedges, mu)
                };
                let antecedent =
                    rule.antecedent.fold(&mut leaf, &|a, b| and.compute(a, b), &|a, b| or.compute(a, b));
                *degree = rule.weight * antecedent;
                // As in fuzzylite (6 to 8), a conclusion's hedges reshape the degree in place,
                // so they also apply to the conclusions after it in the same rule.
                let mut hedged = *degree;
                for conclusion in &rule.conclusions {
                    let output = &self.outputs[conclusion.variable];
                    if !output.enabled {
                        continue;
                    }
                    hedged = Hedge::apply_all(&conclusion.hedges, hedged);
                    // fuzzylite stores degrees through nan_to_num(nan=0, +inf=1, -inf=0).
                    let degree = if hedged.is_nan() {
                        0.0
                    } else if hedged == f64::INFINITY {
                        1.0
                    } else if hedged == f64::NEG_INFINITY {
                        0.0
                    } else {
                        hedged
                    };
                    push_activation(
                        &mut ws.activated[conclusion.variable],
                        output.aggregation,
                        Activation { term: conclusion.term, degree, implication: block.implication },
                    );
                }
            }
        }
    }

    fn defuzzify(&self, ws: &mut Workspace) {
        for (index, (output, sampled)) in self.outputs.iter().zip(&self.sampled).enumerate() {
            if !output.enabled {
                ws.outputs[index] = f64::NAN;
                continue;
            }
            let activated = &ws.activated[index];
            let value = match output.defuzzifier {
                Defuzzifier::Integral { method, .. } => {
                    let ys = &mut ws.aggregated[index];
                    aggregate(sampled, output.aggregation, activated, ys);
                    method.defuzzify(&sampled.xs, ys)
                }
                Defuzzifier::Weighted { method, .. } => {
                    let grouped = &mut ws.grouped[index];
                    grouped.fill(f64::NAN);
                    let combine = output.aggregation.unwrap_or(SNorm::UnboundedSum);
                    for a in activated {
                        let slot = &mut grouped[a.term];
                        *slot = if slot.is_nan() { a.degree } else { combine.compute(*slot, a.degree) };
                    }
                    let terms = output.terms.iter().zip(grouped.iter());
                    method.defuzzify(sampled.kind, terms.filter(|(_, w)| !w.is_nan()).map(|(t, w)| (t, *w)))
                }
            };
            let mut value = value;
            if output.lock_previous && value.is_nan() {
                value = ws.previous[index];
            }
            if value.is_nan() && !output.default.is_nan() {
                value = output.default;
            }
            if output.lock_range {
                value = value.clamp(output.min, output.max);
            }
            ws.previous[index] = value;
            ws.outputs[index] = value;
        }
    }
}

/// Adds an activation, merging it into an earlier one of the same term and implication when
/// the aggregation is `Maximum` (the result is the same, and the sampling loop shorter).
fn push_activation(list: &mut Vec<Activation>, aggregation: Option<SNorm>, new: Activation) {
    if aggregation == Some(SNorm::Maximum)
        && let Some(same) = list.iter_mut().find(|a| a.term == new.term && a.implication == new.implication)
    {
        same.degree = same.degree.max(new.degree);
        return;
    }
    if list.len() < list.capacity() {
        list.push(new);
    }
}

/// Aggregated membership at each sample point: `S` over activations of `I(degree, μ_term(x))`.
fn aggregate(sampled: &SampledOutput, aggregation: Option<SNorm>, activated: &[Activation], ys: &mut [f64]) {
    ys.fill(0.0);
    let n = ys.len();
    let aggregation = aggregation.unwrap_or(SNorm::Maximum);
    for a in activated {
        let mus = &sampled.table[a.term * n..(a.term + 1) * n];
        let implication = a.implication.unwrap_or(TNorm::Minimum);
        match (implication, aggregation) {
            (TNorm::Minimum, SNorm::Maximum) => {
                for (y, mu) in ys.iter_mut().zip(mus) {
                    *y = y.max(a.degree.min(*mu));
                }
            }
            _ => {
                for (y, mu) in ys.iter_mut().zip(mus) {
                    *y = aggregation.compute(*y, implication.compute(a.degree, *mu));
                }
            }
        }
    }
}

impl SampledOutput {
    /// Tabulates `output`'s terms at its defuzzifier's sample points.
    pub(crate) fn new(output: &OutputVariable, kind: WeightedKind, conclusions: usize) -> Self {
        let xs: Vec<f64> = match output.defuzzifier {
            Defuzzifier::Integral { resolution, .. } => {
                (0..resolution).map(|i| midpoint(output.min, output.max, resolution, i)).collect()
            }
            Defuzzifier::Weighted { .. } => Vec::new(),
        };
        let table = output.terms.iter().flat_map(|t| xs.iter().map(|&x| t.membership(x))).collect();
        SampledOutput { xs, table, kind, conclusions }
    }
}

impl Workspace {
    /// Activation degree of every rule in the last inference (weight × antecedent), blocks in
    /// order; 0 for rules of disabled blocks.
    pub fn rule_degrees(&self) -> &[f64] {
        &self.rule_degrees
    }

    /// The crisp outputs of the last inference.
    pub fn outputs(&self) -> &[f64] {
        &self.outputs
    }
}
