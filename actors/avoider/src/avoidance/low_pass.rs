//! A first-order low-pass on a 3-vector, exact for any update interval.

use kestrel_proto::Time;

/// `τ·ẏ = u − y`, discretised exactly for an input held over each interval:
/// `y ← y + (1 − e^(−Δt/τ))·(u − y)`, where `u` is the newest target (the avoider reacts to the
/// frame it has just seen rather than one frame late). The first update seeds `y = u`, since
/// there is no history to smooth against; `τ = 0` passes the target through.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LowPass {
    time_constant_s: f64,
    /// Time of the last update and the output then.
    state: Option<(Time, [f64; 3])>,
}

impl LowPass {
    /// A filter with time constant `time_constant_s` (s, ≥ 0), not yet seeded.
    pub fn new(time_constant_s: f64) -> LowPass {
        LowPass { time_constant_s, state: None }
    }

    /// Changes the time constant (s, ≥ 0) from the next update on, keeping the output.
    pub fn set_time_constant(&mut self, time_constant_s: f64) {
        self.time_constant_s = time_constant_s;
    }

    /// Advances the filter to `time` towards `target` and returns its output. A `time` before
    /// the last update counts as no time passed.
    pub fn update(&mut self, time: Time, target: [f64; 3]) -> [f64; 3] {
        let (time, output) = match self.state {
            None => (time, target),
            Some((last, mut y)) => {
                let dt_s = time.saturating_since(last).as_secs_f64();
                let alpha =
                    if self.time_constant_s > 0.0 { 1.0 - (-dt_s / self.time_constant_s).exp() } else { 1.0 };
                for (y, u) in y.iter_mut().zip(target) {
                    *y += alpha * (u - *y);
                }
                (time.max(last), y)
            }
        };
        self.state = Some((time, output));
        output
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_update_seeds_and_zero_time_constant_passes_through() {
        let mut filter = LowPass::new(0.0);
        assert_eq!(filter.update(Time(0), [1.0, 2.0, 3.0]), [1.0, 2.0, 3.0]);
        assert_eq!(filter.update(Time(1), [-1.0, 0.0, 4.0]), [-1.0, 0.0, 4.0]);
    }

    #[test]
    fn going_back_in_time_changes_nothing() {
        let mut filter = LowPass::new(0.5);
        filter.update(Time(1_000_000), [0.0; 3]);
        assert_eq!(filter.update(Time(500_000), [1.0; 3]), [0.0; 3]);
    }
}
