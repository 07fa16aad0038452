//! Barometer, the maths: height and climb rate (thesis eq. 3.21). When each is fused is
//! [`crate::aiding::baro_control`]'s.
//!
//! Height observes `−p_d`, climb rate observes `−v_d`; both are unit rows. The climb rate
//! is the least-squares slope of the last [`CLIMB_WINDOW`] heights, stamped at the window's mean
//! time (where a slope is unbiased), so it is fused against the state at that time.

use kestrel_proto::Time;
use kestrel_proto::messages::{BaroSample, Innovation};

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

/// Innovation of a height observed as down position `down_m`, gated at `gate_sigma`.
pub fn height_innovation(filter: &Filter, down_m: f64, params: &EkfParams) -> Innovation {
    let h = SparseRow::unit(POS + 2);
    let r = params.baro_height_noise_m.powi(2);
    innovation(down_m - filter.state.pos_ned_m.z, filter.innovation_variance(&h, r), params.baro_gate_sigma)
}

/// Fuses the height innovation `y` (m, down); whether it was taken.
pub fn fuse_height(filter: &mut Filter, y: f64, params: &EkfParams) -> bool {
    filter.fuse(&SparseRow::unit(POS + 2), y, params.baro_height_noise_m.powi(2))
}

/// Innovation of a climb rate, gated at `baro_gate_sigma`.
pub fn climb_rate_innovation(filter: &Filter, climb: &ClimbRate, params: &EkfParams) -> Innovation {
    let h = SparseRow::unit(VEL + 2);
    let r = params.baro_climb_rate_noise_m_s.powi(2);
    let y = -climb.climb_m_s - filter.state.vel_ned_m_s.z;
    innovation(y, filter.innovation_variance(&h, r), params.baro_gate_sigma)
}

/// Fuses the climb-rate innovation `y` (m/s, down); whether it was taken.
pub fn fuse_climb_rate(filter: &mut Filter, y: f64, params: &EkfParams) -> bool {
    filter.fuse(&SparseRow::unit(VEL + 2), y, params.baro_climb_rate_noise_m_s.powi(2))
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
