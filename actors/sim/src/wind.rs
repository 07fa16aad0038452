//! Wind: a steady vector plus gusts, each axis a first-order Gauss–Markov process (the
//! lowest-order shaping filter of the Dryden turbulence model), from its own seeded stream.
//!
//! Two clocks for the gusts. By default the process is stepped with the physics tick from the
//! start of the run. With `gusts_from_take_off` it is a series of its own: drawn every
//! [`GUST_SAMPLE_US`] of the time since the vehicle first left the ground and interpolated
//! linearly between draws, so the gusts are a function of that time and the seed alone. Two
//! simulators with the same seed then fly the same gusts whatever their physics rate and
//! whenever they take off — Kestrel's lockstep graph at 400 Hz and the ArduPilot JSON backend at
//! 1200 Hz, ArduCopter leaving the ground after EKF3's GPS wait
//! (`the_gust_series_is_the_same_whatever_the_tick_and_the_take_off_time`).

use nalgebra::Vector3;
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, finite, non_negative, positive};
use crate::sensors::noise::standard_normal3;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WindParams {
    /// Mean wind the air moves with, north/east/down (m/s); `[3, 0, 0]` blows *towards* north.
    pub steady_ned_m_s: [f64; 3],
    /// 1σ of the gust on each axis (m/s); 0 for steady wind only.
    pub gust_std_m_s: f64,
    /// Correlation time of the gusts (s).
    pub gust_time_constant_s: f64,
    /// Gusts only from take-off on, as a series of the time since then (see the module docs):
    /// the same draw for every simulator with the same seed. Before take-off, steady wind only.
    pub gusts_from_take_off: bool,
}

impl Default for WindParams {
    /// Still air.
    fn default() -> WindParams {
        WindParams {
            steady_ned_m_s: [0.0; 3],
            gust_std_m_s: 0.0,
            gust_time_constant_s: 2.0,
            gusts_from_take_off: false,
        }
    }
}

impl WindParams {
    pub(crate) fn validate(&self) -> Result<(), InvalidParam> {
        finite("steady_ned_m_s", &self.steady_ned_m_s)?;
        non_negative("gust_std_m_s", self.gust_std_m_s)?;
        if self.gust_std_m_s > 0.0 {
            positive("gust_time_constant_s", self.gust_time_constant_s)?;
        }
        Ok(())
    }
}

/// A `wind` fault: the steady wind and gust 1σ that replace the world's while it is active.
#[derive(Clone, Debug, PartialEq)]
pub struct WindFault {
    /// Steady wind, north/east/down (m/s), the direction the air moves towards.
    pub steady_ned_m_s: [f64; 3],
    /// 1σ of the gust on each axis (m/s).
    pub gust_std_m_s: f64,
}

/// Period of the gust series' draws when it runs from take-off (µs): 100 Hz, under the physics
/// ticks of both simulators and far under the gusts' seconds of correlation time.
pub const GUST_SAMPLE_US: u64 = 10_000;

/// The wind's current state.
#[derive(Clone, Debug)]
pub(crate) struct Wind {
    params: WindParams,
    gust_ned_m_s: Vector3<f64>,
    rng: Pcg64,
    /// With `gusts_from_take_off`: the series once the vehicle has left the ground.
    series: Option<GustSeries>,
}

/// A unit-variance Gauss–Markov series drawn every [`GUST_SAMPLE_US`] from time 0, read at any
/// later time by linear interpolation between the draws either side.
#[derive(Clone, Debug)]
struct GustSeries {
    /// Draws made so far; `draws[1]` is at `GUST_SAMPLE_US · index`, `draws[0]` one period before.
    draws: [Vector3<f64>; 2],
    index: u64,
    /// Time since take-off (µs): whole ticks added, so no rounding drifts.
    since_us: u64,
}

impl Wind {
    pub(crate) fn new(params: &WindParams, rng: Pcg64) -> Wind {
        Wind { params: params.clone(), gust_ned_m_s: Vector3::zeros(), rng, series: None }
    }

    /// Advances the gusts by `tick_us` (exact discretisation, stationary variance) and returns the
    /// air velocity (m/s, NED). An active `fault` replaces the steady wind and the gust 1σ; the
    /// gust state carries on through its start and end with the world's correlation time.
    /// `airborne` is whether the vehicle was off the ground at the tick's start: with
    /// `gusts_from_take_off` the series starts at the first such tick.
    pub(crate) fn advance(
        &mut self,
        tick_us: u64,
        airborne: bool,
        fault: Option<&WindFault>,
    ) -> Vector3<f64> {
        let (steady, gust_std) = match fault {
            Some(f) => (f.steady_ned_m_s, f.gust_std_m_s),
            None => (self.params.steady_ned_m_s, self.params.gust_std_m_s),
        };
        if self.params.gusts_from_take_off {
            if self.series.is_none() && airborne {
                // Time 0: the stationary start, one draw scaled to unit variance.
                let first = standard_normal3(&mut self.rng);
                self.series = Some(GustSeries { draws: [first, first], index: 0, since_us: 0 });
            }
            self.gust_ned_m_s = match &mut self.series {
                Some(series) => {
                    series.advance_to(
                        series.since_us + tick_us,
                        self.params.gust_time_constant_s,
                        &mut self.rng,
                    ) * gust_std
                }
                None => Vector3::zeros(),
            };
        } else if gust_std > 0.0 {
            let dt_s = tick_us as f64 * 1e-6;
            let decay = (-dt_s / self.params.gust_time_constant_s).exp();
            let drive = gust_std * (1.0 - decay * decay).sqrt();
            self.gust_ned_m_s = self.gust_ned_m_s * decay + standard_normal3(&mut self.rng) * drive;
        } else {
            self.gust_ned_m_s = Vector3::zeros();
        }
        Vector3::from(steady) + self.gust_ned_m_s
    }
}

impl GustSeries {
    /// The unit gust at `since_us` (µs since take-off, never earlier than the last call's).
    fn advance_to(&mut self, since_us: u64, time_constant_s: f64, rng: &mut Pcg64) -> Vector3<f64> {
        let sample_us = GUST_SAMPLE_US;
        self.since_us = since_us;
        let decay = (-(sample_us as f64 * 1e-6) / time_constant_s).exp();
        let drive = (1.0 - decay * decay).sqrt();
        while self.index * sample_us < since_us {
            self.draws = [self.draws[1], self.draws[1] * decay + standard_normal3(rng) * drive];
            self.index += 1;
        }
        let at_us = self.index * sample_us;
        // Between the draw before (`at_us − sample_us`) and the one at `at_us`.
        let f = 1.0 - (at_us - since_us) as f64 / sample_us as f64;
        self.draws[0] + (self.draws[1] - self.draws[0]) * f
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensors::noise::{Stream, rng};

    #[test]
    fn gusts_have_the_configured_spread_around_the_steady_wind() {
        for gusts_from_take_off in [false, true] {
            let params = WindParams {
                steady_ned_m_s: [3.0, -1.0, 0.0],
                gust_std_m_s: 0.8,
                gust_time_constant_s: 0.5,
                gusts_from_take_off,
            };
            let mut wind = Wind::new(&params, rng(5, Stream::Wind));
            let samples: Vec<Vector3<f64>> = (0..400_000).map(|_| wind.advance(2500, true, None)).collect();
            spread_is(&samples, [3.0, -1.0, 0.0], 0.8);
        }
    }

    /// `samples` average `mean` and spread `sigma` on each axis (within 10 %).
    fn spread_is(samples: &[Vector3<f64>], mean_m_s: [f64; 3], sigma_m_s: f64) {
        let n = samples.len() as f64;
        let mean = samples.iter().sum::<Vector3<f64>>() / n;
        let var = samples.iter().map(|s| (s - mean).component_mul(&(s - mean))).sum::<Vector3<f64>>() / n;
        assert!((mean - Vector3::from(mean_m_s)).norm() < 0.1, "{mean}");
        for sigma in var.map(f64::sqrt).iter() {
            assert!((sigma / sigma_m_s - 1.0).abs() < 0.1, "{var}");
        }
    }

    /// Kestrel's graph ticks every 2500 µs and takes off 1.0 s into its run; a second simulator
    /// ticks every 500 µs and takes off 37.3 s in. At every instant they share (each 2500 µs since
    /// take-off) their gusts are the same numbers; before take-off both blow the steady wind only.
    #[test]
    fn the_gust_series_is_the_same_whatever_the_tick_and_the_take_off_time() {
        let params = WindParams {
            steady_ned_m_s: [0.0, 8.0, 0.0],
            gust_std_m_s: 2.0,
            gust_time_constant_s: 2.0,
            gusts_from_take_off: true,
        };
        let run = |tick_us: u64, take_off_us: u64, until_us: u64| {
            let mut wind = Wind::new(&params, rng(1, Stream::Wind));
            let mut after_take_off = Vec::new();
            let mut t_us = 0;
            while t_us < until_us {
                let airborne = t_us >= take_off_us;
                let air = wind.advance(tick_us, airborne, None);
                if !airborne {
                    assert_eq!(air, Vector3::new(0.0, 8.0, 0.0), "gusts before take-off at {t_us} µs");
                } else {
                    after_take_off.push((t_us + tick_us - take_off_us, air));
                }
                t_us += tick_us;
            }
            after_take_off
        };
        let kestrel = run(2500, 1_000_000, 61_000_000);
        let other: std::collections::HashMap<u64, Vector3<f64>> =
            run(500, 37_300_000, 97_300_000).into_iter().collect();
        assert_eq!(kestrel.len(), 24_000);
        for (since_us, air) in &kestrel {
            assert_eq!(Some(air), other.get(since_us), "at {since_us} µs since take-off");
        }
        // A real draw, not a constant: the gusts spread about their 2 m/s.
        let gusts: Vec<Vector3<f64>> = kestrel.iter().map(|(_, a)| a - Vector3::new(0.0, 8.0, 0.0)).collect();
        assert!(gusts.iter().map(|g| g.norm()).fold(0.0, f64::max) > 2.0);
        // Another seed draws another series.
        let mut wind = Wind::new(&params, rng(2, Stream::Wind));
        assert_ne!(wind.advance(2500, true, None), kestrel[0].1);
    }

    /// Between two draws the gust moves in a straight line: halfway between, it is their mean.
    #[test]
    fn the_series_is_interpolated_between_draws() {
        let mut series = GustSeries { draws: [Vector3::zeros(); 2], index: 0, since_us: 0 };
        let mut draws = rng(3, Stream::Wind);
        let at_10ms = series.advance_to(10_000, 2.0, &mut draws);
        let mut again = GustSeries { draws: [Vector3::zeros(); 2], index: 0, since_us: 0 };
        let at_5ms = again.advance_to(5_000, 2.0, &mut rng(3, Stream::Wind));
        assert!((at_5ms - at_10ms / 2.0).norm() < 1e-12, "{at_5ms} vs {at_10ms}");
    }
}
