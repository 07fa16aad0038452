//! Rules: `if <antecedent> then <conclusions> [with <weight>]`, parsed as fuzzylite parses them
//! ("and" binds tighter than "or", both left-associative, parentheses group; hedges precede
//! the term: `D_c is not very High`).

use crate::error::Cause;
use crate::hedge::Hedge;
use crate::variable::{InputVariable, OutputVariable};

/// `variable is [hedges] term`, with the variable and term resolved to indices.
#[derive(Debug, Clone, PartialEq)]
pub struct Proposition {
    pub variable: usize,
    /// In reading order; applied last-first (the one nearest the term first).
    pub hedges: Vec<Hedge>,
    pub term: usize,
}

/// The condition of a rule.
#[derive(Debug, Clone, PartialEq)]
pub enum Antecedent {
    Is(Proposition),
    And(Box<Antecedent>, Box<Antecedent>),
    Or(Box<Antecedent>, Box<Antecedent>),
}

/// A rule, resolved against the engine's variables.
#[derive(Debug, Clone, PartialEq)]
pub struct Rule {
    /// The text as written, for logs and error messages.
    pub text: String,
    pub antecedent: Antecedent,
    /// Propositions on output variables. Hedges here reshape the activation degree, for this
    /// conclusion and, as fuzzylite does it, for the ones after it.
    pub conclusions: Vec<Proposition>,
    /// Multiplies the antecedent's degree.
    pub weight: f64,
}

impl Antecedent {
    /// Folds the tree: `leaf` for propositions, `and`/`or` to combine.
    pub fn fold<F, A, O>(&self, leaf: &mut F, and: &A, or: &O) -> f64
    where
        F: FnMut(&Proposition) -> f64,
        A: Fn(f64, f64) -> f64,
        O: Fn(f64, f64) -> f64,
    {
        match self {
            Antecedent::Is(p) => leaf(p),
            Antecedent::And(l, r) => {
                let a = l.fold(leaf, and, or);
                let b = r.fold(leaf, and, or);
                and(a, b)
            }
            Antecedent::Or(l, r) => {
                let a = l.fold(leaf, and, or);
                let b = r.fold(leaf, and, or);
                or(a, b)
            }
        }
    }

    /// Whether the antecedent uses `and` / `or` anywhere.
    pub fn uses(&self) -> (bool, bool) {
        match self {
            Antecedent::Is(_) => (false, false),
            Antecedent::And(l, r) | Antecedent::Or(l, r) => {
                let (la, lo) = l.uses();
                let (ra, ro) = r.uses();
                let here_and = matches!(self, Antecedent::And(..));
                (here_and || la || ra, !here_and || lo || ro)
            }
        }
    }

    /// Every proposition, in reading order.
    pub fn propositions(&self, out: &mut Vec<Proposition>) {
        match self {
            Antecedent::Is(p) => out.push(p.clone()),
            Antecedent::And(l, r) | Antecedent::Or(l, r) => {
                l.propositions(out);
                r.propositions(out);
            }
        }
    }
}

/// Parses `text` against the engine's variables.
pub fn parse(text: &str, inputs: &[InputVariable], outputs: &[OutputVariable]) -> Result<Rule, Cause> {
    let text = text.split('#').next().unwrap_or("").trim();
    let spaced = text.replace('(', " ( ").replace(')', " ) ");
    let tokens: Vec<&str> = spaced.split_whitespace().collect();
    if tokens.first() != Some(&"if") {
        return Err(Cause::Syntax(format!("expected a rule 'if … then …', found '{text}'")));
    }
    let then = tokens
        .iter()
        .position(|t| *t == "then")
        .ok_or_else(|| Cause::Syntax(format!("expected keyword 'then' in rule '{text}'")))?;
    let with = tokens.iter().position(|t| *t == "with");
    let (consequent_end, weight) = match with {
        Some(w) if w > then => {
            let rest = &tokens[w + 1..];
            let [number] = rest else {
                return Err(Cause::Syntax(format!("expected one weight after 'with' in rule '{text}'")));
            };
            let weight: f64 = number.parse().map_err(|_| Cause::MalformedNumber((*number).to_string()))?;
            if !(0.0..=1.0).contains(&weight) {
                return Err(Cause::Syntax(format!("rule weight {weight} is outside 0..1 in rule '{text}'")));
            }
            (w, weight)
        }
        Some(_) => {
            return Err(Cause::Syntax(format!("'with' before 'then' in rule '{text}'")));
        }
        None => (tokens.len(), 1.0),
    };
    let mut parser = AntecedentParser { tokens: &tokens[1..then], at: 0, inputs };
    let antecedent = parser.or_expression()?;
    if let Some(extra) = parser.tokens.get(parser.at) {
        return Err(Cause::Syntax(format!("unexpected '{extra}' in the antecedent of rule '{text}'")));
    }
    let conclusions = conclusions(&tokens[then + 1..consequent_end], outputs, text)?;
    Ok(Rule { text: text.to_string(), antecedent, conclusions, weight })
}

struct AntecedentParser<'a> {
    tokens: &'a [&'a str],
    at: usize,
    inputs: &'a [InputVariable],
}

impl<'a> AntecedentParser<'a> {
    fn peek(&self) -> Option<&'a str> {
        self.tokens.get(self.at).copied()
    }

    fn next(&mut self, expected: &str) -> Result<&'a str, Cause> {
        let token =
            self.peek().ok_or_else(|| Cause::Syntax(format!("expected {expected}, found the end")))?;
        self.at += 1;
        Ok(token)
    }

    fn or_expression(&mut self) -> Result<Antecedent, Cause> {
        let mut left = self.and_expression()?;
        while self.peek() == Some("or") {
            self.at += 1;
            let right = self.and_expression()?;
            left = Antecedent::Or(Box::new(left), Box::new(right));
        }
        Ok(left)
    }

    fn and_expression(&mut self) -> Result<Antecedent, Cause> {
        let mut left = self.primary()?;
        while self.peek() == Some("and") {
            self.at += 1;
            let right = self.primary()?;
            left = Antecedent::And(Box::new(left), Box::new(right));
        }
        Ok(left)
    }

    fn primary(&mut self) -> Result<Antecedent, Cause> {
        if self.peek() == Some("(") {
            self.at += 1;
            let inner = self.or_expression()?;
            let close = self.next("')'")?;
            if close != ")" {
                return Err(Cause::Syntax(format!("expected ')', found '{close}'")));
            }
            return Ok(inner);
        }
        let name = self.next("an input variable")?;
        let variable = self
            .inputs
            .iter()
            .position(|v| v.name == name)
            .ok_or_else(|| Cause::UnknownVariable { role: "input", name: name.to_string() })?;
        let is = self.next("'is'")?;
        if is != "is" {
            return Err(Cause::Syntax(format!("expected 'is' after '{name}', found '{is}'")));
        }
        let mut hedges = Vec::new();
        loop {
            let word = self.next("a hedge or a term")?;
            if let Some(hedge) = Hedge::from_word(word) {
                hedges.push(hedge);
                continue;
            }
            let input = &self.inputs[variable];
            let term = input
                .term_index(word)
                .ok_or_else(|| Cause::UnknownTerm { variable: input.name.clone(), term: word.to_string() })?;
            return Ok(Antecedent::Is(Proposition { variable, hedges, term }));
        }
    }
}

fn conclusions(tokens: &[&str], outputs: &[OutputVariable], text: &str) -> Result<Vec<Proposition>, Cause> {
    let mut conclusions = Vec::new();
    for part in tokens.split(|t| *t == "and") {
        let [name, is, words @ .., term] = part else {
            return Err(Cause::Syntax(format!(
                "expected 'VARIABLE is [hedges] TERM' after 'then' in rule '{text}'"
            )));
        };
        if *is != "is" {
            return Err(Cause::Syntax(format!(
                "expected 'is' after '{name}', found '{is}' in rule '{text}'"
            )));
        }
        let variable = outputs
            .iter()
            .position(|v| v.name == *name)
            .ok_or_else(|| Cause::UnknownVariable { role: "output", name: (*name).to_string() })?;
        let hedges = words
            .iter()
            .map(|w| {
                Hedge::from_word(w)
                    .ok_or_else(|| Cause::Syntax(format!("expected a hedge, found '{w}' in rule '{text}'")))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let output = &outputs[variable];
        let term = output
            .term_index(term)
            .ok_or_else(|| Cause::UnknownTerm { variable: output.name.clone(), term: (*term).to_string() })?;
        conclusions.push(Proposition { variable, hedges, term });
    }
    Ok(conclusions)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::defuzzifier::Defuzzifier;
    use crate::term::{Shape, Term};

    fn term(name: &str) -> Term {
        Term { name: name.into(), shape: Shape::Constant { value: 0.5 }, height: 1.0 }
    }

    fn input(name: &str) -> InputVariable {
        InputVariable {
            name: name.into(),
            min: 0.0,
            max: 1.0,
            enabled: true,
            lock_range: false,
            terms: vec![term("x")],
        }
    }

    fn output() -> OutputVariable {
        OutputVariable {
            name: "out".into(),
            min: 0.0,
            max: 1.0,
            enabled: true,
            lock_range: false,
            lock_previous: false,
            default: f64::NAN,
            defuzzifier: Defuzzifier::from_name("Centroid").expect("known"),
            aggregation: None,
            terms: vec![term("y")],
        }
    }

    fn is(variable: usize, hedges: Vec<Hedge>) -> Box<Antecedent> {
        Box::new(Antecedent::Is(Proposition { variable, hedges, term: 0 }))
    }

    #[test]
    fn and_binds_tighter_than_or_and_parentheses_group() {
        let inputs = [input("a"), input("b"), input("c")];
        let outputs = [output()];
        let rule = parse("if a is x or b is not very x and c is x then out is y with 0.5", &inputs, &outputs)
            .expect("parses");
        let expected = Antecedent::Or(
            is(0, vec![]),
            Box::new(Antecedent::And(is(1, vec![Hedge::Not, Hedge::Very]), is(2, vec![]))),
        );
        assert_eq!(rule.antecedent, expected);
        assert_eq!(rule.weight, 0.5);
        let grouped =
            parse("if (a is x or b is x) and c is x then out is y", &inputs, &outputs).expect("parses");
        assert!(matches!(grouped.antecedent, Antecedent::And(..)));
        assert!(parse("if (a is x then out is y", &inputs, &outputs).is_err());
        assert!(parse("if a is x then out is y with 2", &inputs, &outputs).is_err());
    }
}
