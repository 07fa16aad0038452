//! Magnetometer, when to fuse (PX4 EKF2's `mag_control.cpp`).
//!
//! Once aligned (the Earth field comes from the alignment, and once in flight from the in-flight
//! yaw realignment of [`crate::aiding::mag_yaw_reset`]), a sample is fused when its strength is
//! within `mag_strength_tolerance` of the reference field (a stronger or weaker field is a local
//! disturbance: motors, steel, power lines) and its three axes pass `mag_gate_sigma` together.
//! A disturbed sample is skipped and counted: the heading is carried by the gyros (and kept
//! straight by GPS velocity through the covariance) until the field is clean again, and the
//! source is reported not fusing after `mag_timeout_s`. Never reset to a disturbed field.

use kestrel_proto::Time;
use kestrel_proto::messages::{AidingCounters, Innovation, MagSample};
use nalgebra::Vector3;

use crate::aiding::mag_yaw_reset::InFlightYawAlignment;
use crate::aiding::{mag, passes, recent};
use crate::filter::Filter;
use crate::params::EkfParams;

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

    /// Whether the magnetometer was fused within `mag_timeout_s` of `now`.
    pub fn fusing(&self, now: Time, params: &EkfParams) -> bool {
        recent(self.last_fused, now, params.mag_timeout_s)
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
        self.field = mag::field_innovations(filter, &measured, &earth, params);
        if !passes(&self.field) {
            self.counters.rejected += 1;
            return;
        }
        let fused = mag::fuse_field(filter, &measured, &earth, params);
        if fused {
            self.counters.fused += 1;
            self.last_fused = Some(filter.state.time);
        }
    }
}
