//! Membership functions: the shapes a linguistic term can take.
//!
//! Every formula follows fuzzylite 8 (pyfuzzylite's `term.py`) operation for operation, so that
//! the same rule base gives the same numbers here and in fuzzylite: the agreement tests compare
//! the two to 1e-4 of each output's range.

use std::fmt;

/// The shape of a membership function and its parameters, in fuzzylite's order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// `exp(-(x - mean)² / (2 sd²))`.
    Gaussian { mean: f64, sd: f64 },
    /// Zero outside `left..right`, one at `top`, linear in between.
    Triangle { left: f64, top: f64, right: f64 },
    /// Zero outside `bottom_left..bottom_right`, one on `top_left..top_right`.
    Trapezoid { bottom_left: f64, top_left: f64, top_right: f64, bottom_right: f64 },
    /// Generalised bell `1 / (1 + |(x - center) / width|^(2 slope))`.
    Bell { center: f64, width: f64, slope: f64 },
    /// `1 / (1 + exp(-slope (x - inflection)))`.
    Sigmoid { inflection: f64, slope: f64 },
    /// Zero before `start`, one from `end` on, linear in between (decreasing when `end < start`).
    Ramp { start: f64, end: f64 },
    /// The same value everywhere (Takagi–Sugeno consequents).
    Constant { value: f64 },
}

/// The kinds of [`Shape`], named as fuzzylite names them in FLL files.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShapeKind {
    Gaussian,
    Triangle,
    Trapezoid,
    Bell,
    Sigmoid,
    Ramp,
    Constant,
}

impl ShapeKind {
    /// Every kind, for error messages that list what is accepted.
    pub const ALL: [ShapeKind; 7] = [
        ShapeKind::Gaussian,
        ShapeKind::Triangle,
        ShapeKind::Trapezoid,
        ShapeKind::Bell,
        ShapeKind::Sigmoid,
        ShapeKind::Ramp,
        ShapeKind::Constant,
    ];

    /// The kind named `name` (fuzzylite's spelling, case-insensitive).
    pub fn from_name(name: &str) -> Option<ShapeKind> {
        ShapeKind::ALL.into_iter().find(|kind| kind.name().eq_ignore_ascii_case(name))
    }

    /// fuzzylite's name of the kind.
    pub fn name(self) -> &'static str {
        match self {
            ShapeKind::Gaussian => "Gaussian",
            ShapeKind::Triangle => "Triangle",
            ShapeKind::Trapezoid => "Trapezoid",
            ShapeKind::Bell => "Bell",
            ShapeKind::Sigmoid => "Sigmoid",
            ShapeKind::Ramp => "Ramp",
            ShapeKind::Constant => "Constant",
        }
    }

    /// How many shape parameters the kind takes (not counting the optional height).
    pub fn parameter_count(self) -> usize {
        match self {
            ShapeKind::Gaussian | ShapeKind::Sigmoid | ShapeKind::Ramp => 2,
            ShapeKind::Triangle | ShapeKind::Bell => 3,
            ShapeKind::Trapezoid => 4,
            ShapeKind::Constant => 1,
        }
    }

    /// Whether a trailing height parameter is accepted (fuzzylite: all but `Constant`).
    pub fn takes_height(self) -> bool {
        self != ShapeKind::Constant
    }
}

impl fmt::Display for ShapeKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A named membership function of a linguistic variable.
#[derive(Debug, Clone, PartialEq)]
pub struct Term {
    pub name: String,
    pub shape: Shape,
    /// Scales the membership (fuzzylite's optional last parameter); 1 unless given.
    pub height: f64,
}

impl Term {
    /// Degree of membership of `x`, `height · shape(x)`.
    pub fn membership(&self, x: f64) -> f64 {
        let h = self.height;
        match self.shape {
            Shape::Gaussian { mean, sd } => h * (-((x - mean) * (x - mean)) / (2.0 * (sd * sd))).exp(),
            Shape::Triangle { left, top, right } => h * triangle(x, left, top, right),
            Shape::Trapezoid { bottom_left, top_left, top_right, bottom_right } => {
                h * trapezoid(x, bottom_left, top_left, top_right, bottom_right)
            }
            Shape::Bell { center, width, slope } => {
                h * (1.0 / (1.0 + ((x - center) / width).abs().powf(2.0 * slope)))
            }
            Shape::Sigmoid { inflection, slope } => h / (1.0 + (-slope * (x - inflection)).exp()),
            Shape::Ramp { start, end } => h * ramp(x, start, end),
            Shape::Constant { value } => value,
        }
    }

    /// Whether the term is monotonic, so Tsukamoto's inverse [`Term::tsukamoto`] exists.
    pub fn is_monotonic(&self) -> bool {
        matches!(self.shape, Shape::Sigmoid { .. } | Shape::Ramp { .. })
    }

    /// The `x` at which a monotonic term reaches membership `y` (Tsukamoto inference);
    /// for other terms, the membership at `y` as fuzzylite's weighted defuzzifiers use it.
    pub fn tsukamoto(&self, y: f64) -> f64 {
        let h = self.height;
        match self.shape {
            Shape::Ramp { start, end } => start + (end - start) * y / h,
            Shape::Sigmoid { inflection, slope } => inflection + (h / y - 1.0).ln() / -slope,
            _ => self.membership(y),
        }
    }

    /// The points where the term peaks: the interval `[lo, hi]` that must meet the variable's
    /// range for the term to make sense there.
    pub fn peak(&self) -> (f64, f64) {
        match self.shape {
            Shape::Gaussian { mean, .. } => (mean, mean),
            Shape::Triangle { top, .. } => (top, top),
            Shape::Trapezoid { top_left, top_right, .. } => (top_left, top_right),
            Shape::Bell { center, .. } => (center, center),
            Shape::Sigmoid { inflection, .. } => (inflection, inflection),
            Shape::Ramp { start, end } => (start.min(end), start.max(end)),
            Shape::Constant { value } => (value, value),
        }
    }

    /// The kind of the term's shape.
    pub fn kind(&self) -> ShapeKind {
        match self.shape {
            Shape::Gaussian { .. } => ShapeKind::Gaussian,
            Shape::Triangle { .. } => ShapeKind::Triangle,
            Shape::Trapezoid { .. } => ShapeKind::Trapezoid,
            Shape::Bell { .. } => ShapeKind::Bell,
            Shape::Sigmoid { .. } => ShapeKind::Sigmoid,
            Shape::Ramp { .. } => ShapeKind::Ramp,
            Shape::Constant { .. } => ShapeKind::Constant,
        }
    }
}

fn triangle(x: f64, a: f64, b: f64, c: f64) -> f64 {
    if x < a || x > c {
        0.0
    } else if x == b || (a == f64::NEG_INFINITY && x < b) || (c == f64::INFINITY && x > b) {
        1.0
    } else if x < b {
        (x - a) / (b - a)
    } else {
        (c - x) / (c - b)
    }
}

fn trapezoid(x: f64, a: f64, b: f64, c: f64, d: f64) -> f64 {
    if x < a || x > d {
        0.0
    } else if (b <= x && x <= c) || (a == f64::NEG_INFINITY && x < b) || (d == f64::INFINITY && x > c) {
        1.0
    } else if x < b {
        (x - a) / (b - a)
    } else {
        (d - x) / (d - c)
    }
}

fn ramp(x: f64, start: f64, end: f64) -> f64 {
    if start < end {
        if x > start && x < end {
            (x - start) / (end - start)
        } else if x >= end {
            1.0
        } else {
            0.0
        }
    } else if x < start && x > end {
        (start - x) / (start - end)
    } else if x <= end {
        1.0
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn term(shape: Shape) -> Term {
        Term { name: "t".into(), shape, height: 1.0 }
    }

    #[test]
    fn shapes_peak_where_they_should() {
        let g = term(Shape::Gaussian { mean: 0.5, sd: 0.1 });
        assert_eq!(g.membership(0.5), 1.0);
        assert!((g.membership(0.6) - (-0.5f64).exp()).abs() < 1e-15);
        let t = term(Shape::Triangle { left: 0.0, top: 1.0, right: 3.0 });
        assert_eq!(t.membership(0.5), 0.5);
        assert_eq!(t.membership(2.0), 0.5);
        assert_eq!(t.membership(3.5), 0.0);
        let z = term(Shape::Trapezoid { bottom_left: 0.0, top_left: 1.0, top_right: 2.0, bottom_right: 4.0 });
        assert_eq!(z.membership(1.5), 1.0);
        assert_eq!(z.membership(3.0), 0.5);
        let b = term(Shape::Bell { center: 0.0, width: 2.0, slope: 3.0 });
        assert_eq!(b.membership(2.0), 0.5);
        let s = term(Shape::Sigmoid { inflection: 1.0, slope: 4.0 });
        assert_eq!(s.membership(1.0), 0.5);
        let up = term(Shape::Ramp { start: 0.0, end: 2.0 });
        let down = term(Shape::Ramp { start: 2.0, end: 0.0 });
        assert_eq!(up.membership(0.5), 0.25);
        assert_eq!(down.membership(0.5), 0.75);
        assert_eq!(up.membership(3.0), 1.0);
        assert_eq!(down.membership(3.0), 0.0);
        assert_eq!(term(Shape::Constant { value: 0.3 }).membership(9.0), 0.3);
    }

    #[test]
    fn tsukamoto_inverts_monotonic_terms() {
        let up = term(Shape::Ramp { start: 1.0, end: 3.0 });
        assert_eq!(up.tsukamoto(0.5), 2.0);
        let s = term(Shape::Sigmoid { inflection: 1.0, slope: 4.0 });
        assert!((s.membership(s.tsukamoto(0.3)) - 0.3).abs() < 1e-12);
    }
}
