//! Barometer: height and climb rate (thesis eq. 3.21).
//!
//! When: the alignment's mean pressure altitude (over the still window) fixes the offset between
//! pressure altitude and the filter's height, so the barometer observes height changes, not the
//! altitude above sea level; without a barometer during alignment, the first sample after it
//! does.
//! Height and climb rate are each gated at `baro_gate_sigma`.
//!
//! Maths: height observes `−p_d`, climb rate observes `−v_d`; both are unit rows. The climb rate
//! is the least-squares slope of the last [`CLIMB_WINDOW`] heights, stamped at the window's mean
//! time (where a slope is unbiased), so it is fused against the state at that time.

use kestrel_proto::Time;
use kestrel_proto::messages::{AidingCounters, BaroSample, Innovation};

use crate::aiding::innovation;
use crate::covariance::SparseRow;
use crate::filter::Filter;
use crate::params::EkfParams;
use crate::state::{POS, VEL};

/// Samples in the climb-rate slope.
pub const CLIMB_WINDOW: usize = 5;

/// A climb rate differentiated from the barometer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClimbRate {
    /// Mean time of the samples it was fitted to.
    pub time: Time,
    /// Rate of climb (m/s, up positive).
    pub climb_m_s: f64,
}

/// Fits climb rates to the newest barometer samples.
#[derive(Clone, Debug, Default)]
pub struct ClimbRateFit {
    window: [(Time, f64); CLIMB_WINDOW],
    len: usize,
}

impl ClimbRateFit {
    /// Adds a sample; returns the slope once the window is full. Samples must come in time order.
    pub fn push(&mut self, sample: &BaroSample) -> Option<ClimbRate> {
        if self.len == CLIMB_WINDOW {
            self.window.rotate_left(1);
            self.len -= 1;
        }
        self.window[self.len] = (sample.time, sample.altitude_m);
        self.len += 1;
        if self.len < CLIMB_WINDOW {
            return None;
        }
        let t0 = self.window[0].0;
        let ts = self.window.map(|(t, _)| (t - t0).as_secs_f64());
        let n = CLIMB_WINDOW as f64;
        let t_mean = ts.iter().sum::<f64>() / n;
        let h_mean = self.window.iter().map(|w| w.1).sum::<f64>() / n;
        let sxx: f64 = ts.iter().map(|t| (t - t_mean).powi(2)).sum();
        if sxx <= 0.0 {
            return None;
        }
        let sxy: f64 = ts.iter().zip(&self.window).map(|(t, w)| (t - t_mean) * (w.1 - h_mean)).sum();
        Some(ClimbRate {
            time: Time::from_micros(t0.as_micros() + (t_mean * 1e6).round() as u64),
            climb_m_s: sxy / sxx,
        })
    }
}

/// Barometer fusion state.
#[derive(Clone, Debug, Default)]
pub struct BaroControl {
    /// Pressure altitude at zero height (m).
    offset_m: Option<f64>,
    last_fused: Option<Time>,
    pub counters: AidingCounters,
    pub height: Innovation,
    pub climb_rate: Innovation,
}

impl BaroControl {
    /// Sets the pressure altitude of zero height (m), from the alignment's mean.
    pub fn set_datum(&mut self, altitude_m: f64) {
        self.offset_m = Some(altitude_m);
    }

    /// The pressure altitude of zero height (m), once set.
    pub fn datum_m(&self) -> Option<f64> {
        self.offset_m
    }

    /// Whether height was fused within `horizontal_position_timeout_s` of `now`.
    pub fn height_aiding(&self, now: Time, params: &EkfParams) -> bool {
        self.last_fused.is_some_and(|t| (now - t).as_secs_f64() < params.horizontal_position_timeout_s)
    }

    /// Fuses the height of `sample` into `filter` (at the sample's time).
    pub fn fuse_height(&mut self, filter: &mut Filter, sample: &BaroSample, params: &EkfParams) {
        let offset = *self.offset_m.get_or_insert(sample.altitude_m + filter.state.pos_ned_m.z);
        let down_m = offset - sample.altitude_m;
        let h = SparseRow::unit(POS + 2);
        let r = params.baro_height_noise_m.powi(2);
        self.height = innovation(
            down_m - filter.state.pos_ned_m.z,
            filter.innovation_variance(&h, r),
            params.baro_gate_sigma,
        );
        if self.height.test_ratio > 1.0 {
            self.counters.rejected += 1;
            return;
        }
        if filter.fuse(&h, self.height.innovation, r) {
            self.counters.fused += 1;
            self.last_fused = Some(filter.state.time);
        }
    }

    /// Fuses a climb rate into `filter` (at the climb rate's time).
    pub fn fuse_climb_rate(&mut self, filter: &mut Filter, climb: &ClimbRate, params: &EkfParams) {
        let h = SparseRow::unit(VEL + 2);
        let r = params.baro_climb_rate_noise_m_s.powi(2);
        let y = -climb.climb_m_s - filter.state.vel_ned_m_s.z;
        self.climb_rate = innovation(y, filter.innovation_variance(&h, r), params.baro_gate_sigma);
        if self.climb_rate.test_ratio > 1.0 {
            self.counters.rejected += 1;
            return;
        }
        filter.fuse(&h, y, r);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slope_of_a_steady_climb_is_exact_and_stamped_mid_window() {
        let mut fit = ClimbRateFit::default();
        let mut last = None;
        for i in 0..8u64 {
            let s = BaroSample {
                time: Time::from_micros(100_000 * i),
                pressure_pa: 0.0,
                altitude_m: 20.0 + 1.5 * 0.1 * i as f64,
                temperature_c: 20.0,
            };
            last = fit.push(&s).or(last);
        }
        let c = last.unwrap();
        assert!((c.climb_m_s - 1.5).abs() < 1e-9);
        assert_eq!(c.time, Time::from_micros(500_000));
    }
}
