//! Wind: a steady vector plus gusts, each axis a first-order Gauss–Markov process (the
//! lowest-order shaping filter of the Dryden turbulence model), from its own seeded stream.

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
}

impl Default for WindParams {
    /// Still air.
    fn default() -> WindParams {
        WindParams { steady_ned_m_s: [0.0; 3], gust_std_m_s: 0.0, gust_time_constant_s: 2.0 }
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

/// The wind's current state.
#[derive(Clone, Debug)]
pub(crate) struct Wind {
    params: WindParams,
    gust_ned_m_s: Vector3<f64>,
    rng: Pcg64,
}

impl Wind {
    pub(crate) fn new(params: &WindParams, rng: Pcg64) -> Wind {
        Wind { params: params.clone(), gust_ned_m_s: Vector3::zeros(), rng }
    }

    /// Advances the gusts by `dt_s` (exact discretisation, stationary variance) and returns the
    /// air velocity (m/s, NED). An active `fault` replaces the steady wind and the gust 1σ; the
    /// gust state carries on through its start and end with the world's correlation time.
    pub(crate) fn advance(&mut self, dt_s: f64, fault: Option<&WindFault>) -> Vector3<f64> {
        let (steady, gust_std) = match fault {
            Some(f) => (f.steady_ned_m_s, f.gust_std_m_s),
            None => (self.params.steady_ned_m_s, self.params.gust_std_m_s),
        };
        if gust_std > 0.0 {
            let decay = (-dt_s / self.params.gust_time_constant_s).exp();
            let drive = gust_std * (1.0 - decay * decay).sqrt();
            self.gust_ned_m_s = self.gust_ned_m_s * decay + standard_normal3(&mut self.rng) * drive;
        } else {
            self.gust_ned_m_s = Vector3::zeros();
        }
        Vector3::from(steady) + self.gust_ned_m_s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensors::noise::{Stream, rng};

    #[test]
    fn gusts_have_the_configured_spread_around_the_steady_wind() {
        let params =
            WindParams { steady_ned_m_s: [3.0, -1.0, 0.0], gust_std_m_s: 0.8, gust_time_constant_s: 0.5 };
        let mut wind = Wind::new(&params, rng(5, Stream::Wind));
        let samples: Vec<Vector3<f64>> = (0..400_000).map(|_| wind.advance(0.0025, None)).collect();
        let n = samples.len() as f64;
        let mean = samples.iter().sum::<Vector3<f64>>() / n;
        let var = samples.iter().map(|s| (s - mean).component_mul(&(s - mean))).sum::<Vector3<f64>>() / n;
        assert!((mean - Vector3::new(3.0, -1.0, 0.0)).norm() < 0.1, "{mean}");
        for sigma in var.map(f64::sqrt).iter() {
            assert!((sigma / 0.8 - 1.0).abs() < 0.1, "{var}");
        }
    }
}
