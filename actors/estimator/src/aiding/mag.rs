//! Magnetometer: the 3-axis field against the predicted body field `Rᵀ m_earth` (thesis eq.
//! 3.28–3.34).
//!
//! When: once aligned (the Earth field comes from the alignment, and once in flight from the
//! in-flight yaw realignment of [`crate::aiding::mag_yaw_reset`]), for samples whose strength is
//! within `mag_strength_tolerance` of the aligned field (a stronger or weaker field is a local
//! disturbance: motors, steel, power lines). The three axes are gated together at
//! `mag_gate_sigma`.
//!
//! Maths: `∂(Rᵀ m)/∂δθ = Rᵀ [m]×`. Only its column for rotation about NED down is kept, so the
//! magnetometer corrects heading but never roll or pitch (PX4 EKF2 and ArduPilot EKF3 also keep
//! magnetic errors out of tilt): a disturbed field can at worst bias yaw, never the tilt the
//! controllers need most. Each axis is a scalar fusion with one non-zero Jacobian entry.

use kestrel_proto::Time;
use kestrel_proto::messages::{AidingCounters, Innovation, MagSample};
use nalgebra::Vector3;

use crate::aiding::mag_yaw_reset::InFlightYawAlignment;
use crate::aiding::{innovation, passes};
use crate::covariance::SparseRow;
use crate::filter::Filter;
use crate::params::EkfParams;
use crate::state::ATT;

/// Index of the rotation about NED down in the error state.
const YAW: usize = ATT + 2;

/// Magnetometer fusion state.
#[derive(Clone, Debug, Default)]
pub struct MagControl {
    /// The Earth's field in NED from the alignment (gauss).
    earth_ned_gauss: Option<Vector3<f64>>,
    last_fused: Option<Time>,
    in_flight_alignment: InFlightYawAlignment,
    pub counters: AidingCounters,
    pub field: [Innovation; 3],
}

impl MagControl {
    /// Uses `earth_ned_gauss` as the reference field.
    pub fn set_earth_field(&mut self, earth_ned_gauss: Vector3<f64>) {
        self.earth_ned_gauss = Some(earth_ned_gauss);
    }

    /// Whether the magnetometer was fused within `horizontal_position_timeout_s` of `now`.
    pub fn fusing(&self, now: Time, params: &EkfParams) -> bool {
        self.last_fused.is_some_and(|t| (now - t).as_secs_f64() < params.horizontal_position_timeout_s)
    }

    /// Predicted body field and the Jacobian entries (yaw column) for `filter`'s attitude.
    fn predict(filter: &Filter, earth: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
        let r_t = filter.state.attitude.inverse();
        (r_t * earth, r_t * Vector3::new(earth.y, -earth.x, 0.0))
    }

    /// Fuses `sample` into `filter` (at the sample's time).
    pub fn fuse(&mut self, filter: &mut Filter, sample: &MagSample, params: &EkfParams) {
        let measured = Vector3::from(sample.field_gauss);
        if measured.iter().all(|x| x.is_finite())
            && let Some(r) = self.in_flight_alignment.push(filter, sample, params)
        {
            tracing::info!(
                time = %sample.time,
                yaw_change_deg = r.yaw_change_rad.to_degrees(),
                "in-flight yaw realignment from the magnetometer"
            );
            filter.reset_yaw(r.yaw_change_rad, r.variance_rad2);
            self.earth_ned_gauss = Some(r.earth_ned_gauss);
            self.counters.resets += 1;
        }
        let Some(earth) = self.earth_ned_gauss else { return };
        if !measured.iter().all(|x| x.is_finite())
            || (measured.norm() / earth.norm() - 1.0).abs() > params.mag_strength_tolerance
        {
            self.counters.rejected += 1;
            return;
        }
        let r = params.mag_noise_gauss.powi(2);
        let (predicted, jacobian) = Self::predict(filter, &earth);
        for (axis, innov) in self.field.iter_mut().enumerate() {
            let h = SparseRow::unit_scaled(YAW, jacobian[axis]);
            *innov = innovation(
                measured[axis] - predicted[axis],
                filter.innovation_variance(&h, r),
                params.mag_gate_sigma,
            );
        }
        if !passes(&self.field) {
            self.counters.rejected += 1;
            return;
        }
        let mut fused = false;
        for axis in 0..3 {
            let (predicted, jacobian) = Self::predict(filter, &earth);
            let h = SparseRow::unit_scaled(YAW, jacobian[axis]);
            fused |= filter.fuse(&h, measured[axis] - predicted[axis], r);
        }
        if fused {
            self.counters.fused += 1;
            self.last_fused = Some(filter.state.time);
        }
    }
}
