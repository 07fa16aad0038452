//! Airframe drag: a linear term (rotor induced drag, dominant at low speed) plus a quadratic
//! term (body form drag), both opposing the velocity *relative to the air*. Isotropic: a
//! multirotor's drag differs little between axes at the speeds it flies, and the estimator does
//! not model it anyway.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, non_negative};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DragParams {
    /// Force per unit airspeed (N per m/s).
    pub linear_n_per_m_s: f64,
    /// Force per unit airspeed squared (N per (m/s)²).
    pub quadratic_n_per_m2_s2: f64,
}

impl Default for DragParams {
    /// About 6 N at 10 m/s for a 450-size quad, i.e. a 22° lean to hold that speed.
    fn default() -> DragParams {
        DragParams { linear_n_per_m_s: 0.15, quadratic_n_per_m2_s2: 0.045 }
    }
}

impl DragParams {
    pub(crate) fn validate(&self) -> Result<(), InvalidParam> {
        non_negative("linear_n_per_m_s", self.linear_n_per_m_s)?;
        non_negative("quadratic_n_per_m2_s2", self.quadratic_n_per_m2_s2)
    }

    /// Drag force (N, NED) for an airspeed vector `air_velocity_ned_m_s`.
    pub(crate) fn force_ned_n(&self, air_velocity_ned_m_s: &Vector3<f64>) -> Vector3<f64> {
        let speed = air_velocity_ned_m_s.norm();
        -(self.linear_n_per_m_s + self.quadratic_n_per_m2_s2 * speed) * air_velocity_ned_m_s
    }
}
