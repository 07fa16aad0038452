//! A spline leg: the cubic Hermite curve a NAV_SPLINE_WAYPOINT is flown along, from where the
//! leg starts to the waypoint, with Catmull-Rom tangents (half the chord from the point before
//! to the point after), so that consecutive spline legs join with the same direction and speed
//! and the curve passes through every waypoint, as ArduCopter's `SplineCurve` legs do.
//!
//! Positions are NED (m); the curve parameter `s` runs 0 → 1 from the start to the waypoint.
//! Held by `tests::the_curve_passes_through_both_ends_with_the_given_tangents` and
//! `tests::consecutive_legs_join_smoothly`.

use nalgebra::Vector3;

/// One leg of a spline path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplineLeg {
    start: Vector3<f64>,
    end: Vector3<f64>,
    /// dP/ds at the start and at the end (m per unit of `s`).
    start_tangent: Vector3<f64>,
    end_tangent: Vector3<f64>,
}

impl SplineLeg {
    /// The leg from `start` to `end`: it leaves `start` along `start_tangent` (the previous
    /// leg's end tangent when it was a spline, otherwise straight at the waypoint) and arrives
    /// along the Catmull-Rom tangent towards `next` (the waypoint after, when there is one to
    /// fly on to), or comes to a stop at `end` (no next point).
    pub fn new(
        start: Vector3<f64>,
        end: Vector3<f64>,
        start_tangent: Option<Vector3<f64>>,
        next: Option<Vector3<f64>>,
    ) -> SplineLeg {
        let start_tangent = start_tangent.unwrap_or(end - start);
        let end_tangent = next.map_or_else(Vector3::zeros, |n| (n - start) * 0.5);
        SplineLeg { start, end, start_tangent, end_tangent }
    }

    /// The point at `s` (clamped to 0..=1).
    pub fn position(&self, s: f64) -> Vector3<f64> {
        let s = s.clamp(0.0, 1.0);
        let (s2, s3) = (s * s, s * s * s);
        let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
        let h10 = s3 - 2.0 * s2 + s;
        let h01 = -2.0 * s3 + 3.0 * s2;
        let h11 = s3 - s2;
        self.start * h00 + self.start_tangent * h10 + self.end * h01 + self.end_tangent * h11
    }

    /// dP/ds at `s` (clamped to 0..=1), m per unit of `s`.
    pub fn tangent(&self, s: f64) -> Vector3<f64> {
        let s = s.clamp(0.0, 1.0);
        let s2 = s * s;
        let d00 = 6.0 * s2 - 6.0 * s;
        let d10 = 3.0 * s2 - 4.0 * s + 1.0;
        let d01 = -6.0 * s2 + 6.0 * s;
        let d11 = 3.0 * s2 - 2.0 * s;
        self.start * d00 + self.start_tangent * d10 + self.end * d01 + self.end_tangent * d11
    }

    /// The tangent the leg ends with: the next spline leg starts along it.
    pub fn end_tangent(&self) -> Vector3<f64> {
        self.end_tangent
    }

    pub fn end(&self) -> Vector3<f64> {
        self.end
    }

    /// `s` moved on by `distance_m` (m) along the curve (one Euler step of ds = dl / |dP/ds|;
    /// the caller moves a few cm a step, so the error is far below a metre per leg). Where the
    /// tangent vanishes (a leg ending at a stop) the step is taken along the chord's length.
    pub fn advance(&self, s: f64, distance_m: f64) -> f64 {
        let speed = self.tangent(s).norm().max(0.05 * (self.end - self.start).norm()).max(1e-3);
        (s + distance_m.max(0.0) / speed).min(1.0)
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::SplineLeg;

    #[test]
    fn the_curve_passes_through_both_ends_with_the_given_tangents() {
        let (a, b, n) =
            (Vector3::new(0.0, 0.0, -10.0), Vector3::new(20.0, 5.0, -12.0), Vector3::new(30.0, 30.0, -12.0));
        let leg = SplineLeg::new(a, b, Some(Vector3::new(3.0, 1.0, 0.0)), Some(n));
        assert!((leg.position(0.0) - a).norm() < 1e-12);
        assert!((leg.position(1.0) - b).norm() < 1e-12);
        assert!((leg.tangent(0.0) - Vector3::new(3.0, 1.0, 0.0)).norm() < 1e-12);
        assert!((leg.tangent(1.0) - (n - a) * 0.5).norm() < 1e-12);
        // The tangent is the derivative of the position (central difference).
        for i in 1..10 {
            let s = f64::from(i) / 10.0;
            let numeric = (leg.position(s + 1e-6) - leg.position(s - 1e-6)) / 2e-6;
            assert!((numeric - leg.tangent(s)).norm() < 1e-5, "s = {s}");
        }
    }

    #[test]
    fn consecutive_legs_join_smoothly() {
        let pts =
            [Vector3::new(0.0, 0.0, -10.0), Vector3::new(20.0, 0.0, -10.0), Vector3::new(20.0, 20.0, -10.0)];
        let first = SplineLeg::new(pts[0], pts[1], None, Some(pts[2]));
        let second = SplineLeg::new(pts[1], pts[2], Some(first.end_tangent()), None);
        assert!((first.position(1.0) - second.position(0.0)).norm() < 1e-12, "continuous");
        assert!((first.tangent(1.0) - second.tangent(0.0)).norm() < 1e-12, "same direction and speed");
        assert!(second.tangent(1.0).norm() < 1e-12, "stops at the last point");
        // Walking the leg in small steps ends at the waypoint, not short of it.
        let mut s = 0.0;
        for _ in 0..100_000 {
            s = second.advance(s, 0.05);
        }
        assert_eq!(s, 1.0);
    }
}
