//! GPS, the maths: north/east position, north/east/down velocity and (when the barometer has
//! failed) height as observations of the filter (thesis eq. 3.20, 3.22–3.27). When each is fused
//! is [`crate::aiding::gps_control`]'s.
//!
//! Every observation is a state directly (`H` a unit row), fused as sequential scalars; the
//! observation variance is the larger of the configured noise and the receiver's accuracy.

use kestrel_proto::messages::{GpsFix, Innovation};
use nalgebra::Vector3;

use crate::aiding::innovation;
use crate::covariance::SparseRow;
use crate::filter::Filter;
use crate::params::EkfParams;
use crate::state::{POS, VEL};

/// One fix in the filter's local frame, with the variances it is fused with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpsObservation {
    /// Position in the local NED frame (m).
    pub pos_ned_m: Vector3<f64>,
    pub vel_ned_m_s: Vector3<f64>,
    /// North/east position variance (m²).
    pub pos_var_m2: f64,
    /// Height variance (m²), from the receiver's vertical accuracy.
    pub height_var_m2: f64,
    /// Velocity variance per axis (m²/s²).
    pub vel_var_m2_s2: f64,
}

impl GpsObservation {
    /// `fix` at `pos_ned_m` in the local frame, with `params`' noise floors.
    pub fn new(fix: &GpsFix, pos_ned_m: [f64; 3], params: &EkfParams) -> GpsObservation {
        GpsObservation {
            pos_ned_m: Vector3::from(pos_ned_m),
            vel_ned_m_s: Vector3::from(fix.vel_ned_m_s),
            pos_var_m2: params.gps_position_noise_m.max(fix.h_acc_m).powi(2),
            height_var_m2: params.gps_height_noise_m.max(fix.v_acc_m).powi(2),
            vel_var_m2_s2: params.gps_velocity_noise_m_s.max(fix.s_acc_m_s).powi(2),
        }
    }
}

/// Innovations of the three velocity axes, gated at `gate_sigma`.
pub fn velocity_innovations(filter: &Filter, obs: &GpsObservation, gate_sigma: f64) -> [Innovation; 3] {
    std::array::from_fn(|axis| {
        let h = SparseRow::unit(VEL + axis);
        innovation(
            obs.vel_ned_m_s[axis] - filter.state.vel_ned_m_s[axis],
            filter.innovation_variance(&h, obs.vel_var_m2_s2),
            gate_sigma,
        )
    })
}

/// Innovations of north and east position, gated at `gate_sigma`.
pub fn position_innovations(filter: &Filter, obs: &GpsObservation, gate_sigma: f64) -> [Innovation; 2] {
    std::array::from_fn(|axis| {
        let h = SparseRow::unit(POS + axis);
        innovation(
            obs.pos_ned_m[axis] - filter.state.pos_ned_m[axis],
            filter.innovation_variance(&h, obs.pos_var_m2),
            gate_sigma,
        )
    })
}

/// Innovation of the height (as down position), gated at `gate_sigma`.
pub fn height_innovation(filter: &Filter, obs: &GpsObservation, gate_sigma: f64) -> Innovation {
    let h = SparseRow::unit(POS + 2);
    innovation(
        obs.pos_ned_m.z - filter.state.pos_ned_m.z,
        filter.innovation_variance(&h, obs.height_var_m2),
        gate_sigma,
    )
}

/// Fuses the velocity; whether any axis was taken.
pub fn fuse_velocity(filter: &mut Filter, obs: &GpsObservation) -> bool {
    (0..3).fold(false, |fused, axis| {
        let y = obs.vel_ned_m_s[axis] - filter.state.vel_ned_m_s[axis];
        filter.fuse(&SparseRow::unit(VEL + axis), y, obs.vel_var_m2_s2) | fused
    })
}

/// Fuses north and east position; whether either was taken.
pub fn fuse_position(filter: &mut Filter, obs: &GpsObservation) -> bool {
    (0..2).fold(false, |fused, axis| {
        let y = obs.pos_ned_m[axis] - filter.state.pos_ned_m[axis];
        filter.fuse(&SparseRow::unit(POS + axis), y, obs.pos_var_m2) | fused
    })
}

/// Fuses the height; whether it was taken.
pub fn fuse_height(filter: &mut Filter, obs: &GpsObservation) -> bool {
    let y = obs.pos_ned_m.z - filter.state.pos_ned_m.z;
    filter.fuse(&SparseRow::unit(POS + 2), y, obs.height_var_m2)
}
