//! Hedges: words that reshape a membership degree ("not", "very", …), as fuzzylite defines them.

/// A linguistic hedge. In a rule `A is very B`, the degree of `A is B` goes through the hedge.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Hedge {
    /// `1 − x`.
    Not,
    /// `x²`.
    Very,
    /// `√x`.
    Somewhat,
    /// `2x²` below one half, `1 − 2(1 − x)²` above.
    Extremely,
    /// `√(x/2)` below one half, `1 − √((1 − x)/2)` above.
    Seldom,
}

impl Hedge {
    /// The hedge spelled `word` in rules, if any.
    pub fn from_word(word: &str) -> Option<Hedge> {
        match word {
            "not" => Some(Hedge::Not),
            "very" => Some(Hedge::Very),
            "somewhat" => Some(Hedge::Somewhat),
            "extremely" => Some(Hedge::Extremely),
            "seldom" => Some(Hedge::Seldom),
            _ => None,
        }
    }

    /// Applies the hedge to a membership degree.
    pub fn apply(self, x: f64) -> f64 {
        match self {
            Hedge::Not => 1.0 - x,
            Hedge::Very => x * x,
            Hedge::Somewhat => x.sqrt(),
            Hedge::Extremely => {
                if x <= 0.5 {
                    2.0 * (x * x)
                } else {
                    1.0 - 2.0 * ((1.0 - x) * (1.0 - x))
                }
            }
            Hedge::Seldom => {
                if x <= 0.5 {
                    (0.5 * x).sqrt()
                } else {
                    1.0 - (0.5 * (1.0 - x)).sqrt()
                }
            }
        }
    }

    /// Applies a proposition's hedges the way fuzzylite does: the one nearest the term first.
    pub fn apply_all(hedges: &[Hedge], x: f64) -> f64 {
        hedges.iter().rev().fold(x, |y, hedge| hedge.apply(y))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn not_very_applies_very_first() {
        assert_eq!(Hedge::apply_all(&[Hedge::Not, Hedge::Very], 0.5), 0.75);
        assert_eq!(Hedge::apply_all(&[Hedge::Very, Hedge::Not], 0.5), 0.25);
        assert_eq!(Hedge::Extremely.apply(0.25), 0.125);
        assert_eq!(Hedge::Seldom.apply(0.5), 0.5);
    }
}
