//! GPS: north/east position and north/east/down velocity (thesis eq. 3.20, 3.22–3.27).
//!
//! When: a fix is used with a 3D fix, enough satellites and a sane accuracy. The first one sets
//! the local NED origin. Position (north and east together) and velocity (three axes together)
//! are gated separately at `gps_gate_sigma`; a position rejected for longer than
//! `gps_reset_timeout_s` resets position and velocity to GPS, as does the first fix after the
//! filter has dead reckoned past `horizontal_position_timeout_s`.
//!
//! The origin's altitude is the mean, over the first [`ORIGIN_ALTITUDE_FIXES`] fixes, of GPS
//! altitude plus the filter's height at each fix: heights come from the barometer, so this
//! anchors them above sea level with the GPS noise averaged down (one fix's vertical error, about
//! a metre, would otherwise stay in every geodetic altitude the filter reports). Only the
//! geodetic anchor moves; local NED positions are untouched.
//!
//! Maths: every observation is a state directly (`H` a unit row), fused as sequential scalars;
//! the observation variance is the larger of the configured noise and the receiver's accuracy.

use kestrel_proto::Time;
use kestrel_proto::geo::{Geodetic, LocalFrame};
use kestrel_proto::messages::{AidingCounters, GpsFix, GpsFixType, Innovation};
use nalgebra::Vector3;

use crate::aiding::{innovation, passes};
use crate::covariance::SparseRow;
use crate::filter::Filter;
use crate::params::EkfParams;
use crate::state::{POS, VEL};

/// Fixes averaged into the origin's altitude (10 s at 5 Hz).
pub const ORIGIN_ALTITUDE_FIXES: u32 = 50;

/// GPS fusion state.
#[derive(Clone, Debug, Default)]
pub struct GpsControl {
    /// Sum of GPS altitude plus filter height over the fixes averaged so far, and their count.
    origin_altitude: (f64, u32),
    last_position_fused: Option<Time>,
    last_velocity_fused: Option<Time>,
    /// Start of the current run of rejected positions.
    rejecting_since: Option<Time>,
    pub counters: AidingCounters,
    pub position: [Innovation; 2],
    pub velocity: [Innovation; 3],
}

impl GpsControl {
    /// Whether GPS position was fused within `horizontal_position_timeout_s` of `now`.
    pub fn position_aiding(&self, now: Time, params: &EkfParams) -> bool {
        self.last_position_fused
            .is_some_and(|t| (now - t).as_secs_f64() < params.horizontal_position_timeout_s)
    }

    /// Whether GPS velocity was fused within `horizontal_position_timeout_s` of `now`.
    pub fn velocity_aiding(&self, now: Time, params: &EkfParams) -> bool {
        self.last_velocity_fused
            .is_some_and(|t| (now - t).as_secs_f64() < params.horizontal_position_timeout_s)
    }

    /// Fuses `fix` into `filter` (both at the fix's time); sets `frame` from the first good fix.
    pub fn fuse(
        &mut self,
        filter: &mut Filter,
        fix: &GpsFix,
        frame: &mut Option<LocalFrame>,
        params: &EkfParams,
    ) {
        if !usable(fix, params) {
            return;
        }
        let now = filter.state.time;
        let pos_var = params.gps_position_noise_m.max(fix.h_acc_m).powi(2);
        let vel_var = params.gps_velocity_noise_m_s.max(fix.s_acc_m_s).powi(2);
        let vel = Vector3::from(fix.vel_ned_m_s);
        let geodetic = Geodetic { lat_deg: fix.lat_deg, lon_deg: fix.lon_deg, alt_m: fix.alt_msl_m };
        let Some(local) = frame else {
            let origin = Geodetic { alt_m: fix.alt_msl_m + filter.state.pos_ned_m.z, ..geodetic };
            self.origin_altitude = (origin.alt_m, 1);
            *frame = Some(LocalFrame::new(origin));
            self.reset(filter, [0.0, 0.0], vel, pos_var, vel_var, now);
            return;
        };
        if self.origin_altitude.1 < ORIGIN_ALTITUDE_FIXES {
            let (sum, n) = self.origin_altitude;
            self.origin_altitude = (sum + fix.alt_msl_m + filter.state.pos_ned_m.z, n + 1);
            let alt_m = self.origin_altitude.0 / f64::from(n + 1);
            *local = LocalFrame::new(Geodetic { alt_m, ..local.home() });
        }
        let ned = local.to_ned(geodetic);
        if !self.position_aiding(now, params) {
            tracing::info!(time = %now, "GPS resumed after dead reckoning: resetting position and velocity");
            self.reset(filter, [ned[0], ned[1]], vel, pos_var, vel_var, now);
            return;
        }
        let gate = params.gps_gate_sigma;
        let mut rejected = false;
        let mut fused = false;

        for (axis, innov) in self.velocity.iter_mut().enumerate() {
            let h = SparseRow::unit(VEL + axis);
            *innov = innovation(
                vel[axis] - filter.state.vel_ned_m_s[axis],
                filter.innovation_variance(&h, vel_var),
                gate,
            );
        }
        if passes(&self.velocity) {
            for axis in 0..3 {
                let y = vel[axis] - filter.state.vel_ned_m_s[axis];
                fused |= filter.fuse(&SparseRow::unit(VEL + axis), y, vel_var);
            }
            self.last_velocity_fused = Some(now);
        } else {
            rejected = true;
        }

        for (axis, innov) in self.position.iter_mut().enumerate() {
            let h = SparseRow::unit(POS + axis);
            *innov = innovation(
                ned[axis] - filter.state.pos_ned_m[axis],
                filter.innovation_variance(&h, pos_var),
                gate,
            );
        }
        if passes(&self.position) {
            for (axis, measured) in ned.iter().take(2).enumerate() {
                let y = measured - filter.state.pos_ned_m[axis];
                fused |= filter.fuse(&SparseRow::unit(POS + axis), y, pos_var);
            }
            self.last_position_fused = Some(now);
            self.rejecting_since = None;
        } else {
            rejected = true;
            let since = *self.rejecting_since.get_or_insert(now);
            if (now - since).as_secs_f64() > params.gps_reset_timeout_s {
                tracing::warn!(time = %now, "GPS position rejected for too long: resetting to GPS");
                self.reset(filter, [ned[0], ned[1]], vel, pos_var, vel_var, now);
                return;
            }
        }
        self.counters.fused += u64::from(fused);
        self.counters.rejected += u64::from(rejected);
    }

    fn reset(
        &mut self,
        filter: &mut Filter,
        ne: [f64; 2],
        vel: Vector3<f64>,
        pos_var: f64,
        vel_var: f64,
        now: Time,
    ) {
        filter.reset_horizontal_position(ne, pos_var);
        filter.reset_velocity(vel, vel_var);
        self.counters.resets += 1;
        self.last_position_fused = Some(now);
        self.last_velocity_fused = Some(now);
        self.rejecting_since = None;
    }
}

/// Whether a fix is good enough to use at all.
fn usable(fix: &GpsFix, params: &EkfParams) -> bool {
    fix.fix_type >= GpsFixType::Fix3d
        && fix.satellites >= params.gps_min_satellites
        && fix.h_acc_m <= params.gps_max_h_acc_m
        && [fix.lat_deg, fix.lon_deg, fix.alt_msl_m, fix.h_acc_m, fix.s_acc_m_s].iter().all(|x| x.is_finite())
        && fix.vel_ned_m_s.iter().all(|x| x.is_finite())
        && fix.lat_deg.abs() <= 90.0
        && fix.lon_deg.abs() <= 180.0
}
