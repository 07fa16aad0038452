//! The fastest a vehicle may fly towards what it cannot see past: it must still stop, with a
//! margin, inside the range its camera vouches for. Shared by the avoider (its
//! forward cap on the correction) and the commander (its cap on the flown demand), so the
//! braking model is written once.
//!
//! At speed `v` the vehicle covers `v·t` before it starts to brake (frame → setpoint latency
//! plus reaction) and `v²/(2a)` while braking at `a`; it wants `margin` left over. The cap is
//! the largest `v` with `v²/(2a) + v·t + margin ≤ range`:
//! `v = −a·t + √((a·t)² + 2a·(range − margin))`, computed as `2a·r / (a·t + √((a·t)² + 2a·r))`
//! (`r = range − margin`) so that a long latency and a short room do not cancel digits. PX4's
//! collision prevention limits its setpoint the same way (`CP_DIST` the margin, `CP_DELAY` plus
//! the data's age the latency, `MPC_ACC_HOR` the braking).

/// What the cap assumes of the vehicle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Braking {
    /// Deceleration the controller can actually fly (m/s², > 0).
    pub decel_m_s2: f64,
    /// Time from the view being captured to the vehicle braking (s, ≥ 0).
    pub latency_s: f64,
    /// Clearance left when stopped (m, ≥ 0).
    pub margin_m: f64,
}

/// An input the cap cannot be computed from; nothing is passed on.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[error("speed cap: {field} = {value} must be {expected}")]
pub struct SpeedCapError {
    pub field: &'static str,
    pub value: f64,
    pub expected: &'static str,
}

impl Braking {
    /// Refuses NaN, infinities and out-of-range values, naming the first.
    pub fn check(&self) -> Result<(), SpeedCapError> {
        let bad = |field, value: f64, expected| Err(SpeedCapError { field, value, expected });
        if !(self.decel_m_s2.is_finite() && self.decel_m_s2 > 0.0) {
            return bad("decel_m_s2", self.decel_m_s2, "finite and > 0");
        }
        for (field, value) in [("latency_s", self.latency_s), ("margin_m", self.margin_m)] {
            if !(value.is_finite() && value >= 0.0) {
                return bad(field, value, "finite and ≥ 0");
            }
        }
        Ok(())
    }

    /// Distance (m) the vehicle needs from `speed_m_s` to stop with the margin left:
    /// `v²/(2a) + v·t + margin`.
    pub fn stopping_distance_m(&self, speed_m_s: f64) -> f64 {
        speed_m_s * speed_m_s / (2.0 * self.decel_m_s2) + speed_m_s * self.latency_s + self.margin_m
    }

    /// The largest speed (m/s) from which the vehicle stops within `range_m` with the margin
    /// left; 0 when the range is no more than the margin. A range must be finite and ≥ 0: an
    /// infinite one would lift the cap, so "nothing in view" is the caller's finite figure.
    pub fn speed_cap_m_s(&self, range_m: f64) -> Result<f64, SpeedCapError> {
        self.check()?;
        if !(range_m.is_finite() && range_m >= 0.0) {
            return Err(SpeedCapError { field: "range_m", value: range_m, expected: "finite and ≥ 0" });
        }
        let room_m = range_m - self.margin_m;
        if room_m <= 0.0 {
            return Ok(0.0);
        }
        let a = self.decel_m_s2;
        let at = a * self.latency_s;
        Ok(2.0 * a * room_m / (at + (at * at + 2.0 * a * room_m).sqrt()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn braking(decel_m_s2: f64, latency_s: f64, margin_m: f64) -> Braking {
        Braking { decel_m_s2, latency_s, margin_m }
    }

    #[test]
    fn hand_computed_caps() {
        // a = 2, t = 0.5, margin 1, range 9: v²/4 + v/2 = 8 → v² + 2v − 32 = 0 → v = −1 + √33.
        let cap = braking(2.0, 0.5, 1.0).speed_cap_m_s(9.0).unwrap();
        assert!((cap - (33f64.sqrt() - 1.0)).abs() < 1e-12, "{cap}");
        // No latency: v = √(2·a·room) = √(2·2.5·5) = 5.
        assert!((braking(2.5, 0.0, 0.0).speed_cap_m_s(5.0).unwrap() - 5.0).abs() < 1e-12);
        // Braking without limit: v = room / t = 3 / 0.5 = 6 as a → ∞.
        let fast = braking(1e12, 0.5, 1.0).speed_cap_m_s(4.0).unwrap();
        assert!((fast - 6.0).abs() < 1e-6, "{fast}");
        // At and inside the margin: stop.
        assert_eq!(braking(2.0, 0.3, 2.0).speed_cap_m_s(2.0).unwrap(), 0.0);
        assert_eq!(braking(2.0, 0.3, 2.0).speed_cap_m_s(0.5).unwrap(), 0.0);
        assert_eq!(braking(2.0, 0.0, 0.0).speed_cap_m_s(0.0).unwrap(), 0.0);
    }

    #[test]
    fn refuses_what_it_cannot_use() {
        let ok = braking(2.0, 0.3, 1.0);
        for range in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -0.1] {
            let e = ok.speed_cap_m_s(range).unwrap_err();
            assert_eq!(e.field, "range_m");
            assert!(e.value.is_nan() || e.value == range);
        }
        for (b, field) in [
            (braking(0.0, 0.3, 1.0), "decel_m_s2"),
            (braking(-1.0, 0.3, 1.0), "decel_m_s2"),
            (braking(f64::INFINITY, 0.3, 1.0), "decel_m_s2"),
            (braking(f64::NAN, 0.3, 1.0), "decel_m_s2"),
            (braking(2.0, -0.1, 1.0), "latency_s"),
            (braking(2.0, f64::NAN, 1.0), "latency_s"),
            (braking(2.0, 0.3, f64::INFINITY), "margin_m"),
            (braking(2.0, 0.3, -1.0), "margin_m"),
        ] {
            assert_eq!(b.speed_cap_m_s(5.0).unwrap_err().field, field, "{b:?}");
        }
    }

    fn any_braking() -> impl Strategy<Value = Braking> {
        (0.1f64..20.0, 0.0f64..2.0, 0.0f64..5.0).prop_map(|(a, t, m)| braking(a, t, m))
    }

    proptest! {
        #[test]
        fn the_stop_from_the_cap_fits_the_range(b in any_braking(), range in 0.0f64..200.0) {
            let cap = b.speed_cap_m_s(range).unwrap();
            prop_assert!(cap.is_finite() && cap >= 0.0);
            if range > b.margin_m {
                prop_assert!(b.stopping_distance_m(cap) <= range * (1.0 + 1e-12) + 1e-12);
                // ... and it is the largest such speed.
                prop_assert!(b.stopping_distance_m(cap * (1.0 + 1e-9) + 1e-9) > range);
            } else {
                prop_assert_eq!(cap, 0.0);
            }
        }

        #[test]
        fn more_range_never_lowers_the_cap(b in any_braking(), r in 0.0f64..200.0, more in 0.0f64..50.0) {
            prop_assert!(b.speed_cap_m_s(r + more).unwrap() >= b.speed_cap_m_s(r).unwrap());
        }

        #[test]
        fn worse_braking_never_raises_the_cap(b in any_braking(), r in 0.0f64..200.0, k in 1.0f64..3.0) {
            let cap = b.speed_cap_m_s(r).unwrap();
            let slower = Braking { decel_m_s2: b.decel_m_s2 / k, ..b };
            let later = Braking { latency_s: b.latency_s * k, ..b };
            prop_assert!(slower.speed_cap_m_s(r).unwrap() <= cap * (1.0 + 1e-12));
            prop_assert!(later.speed_cap_m_s(r).unwrap() <= cap * (1.0 + 1e-12));
        }
    }
}
