//! Magnetometer, the maths: the 3-axis field against the predicted body field `Rᵀ m_earth`
//! (thesis eq. 3.28–3.34). When it is fused is [`crate::aiding::mag_control`]'s.
//!
//! `∂(Rᵀ m)/∂δθ = Rᵀ [m]×`. Only its column for rotation about NED down is kept, so the
//! magnetometer corrects heading but never roll or pitch (PX4 EKF2 and ArduPilot EKF3 also keep
//! magnetic errors out of tilt): a disturbed field can at worst bias yaw, never the tilt the
//! controllers need most. Each axis is a scalar fusion with one non-zero Jacobian entry.

use kestrel_proto::messages::Innovation;
use nalgebra::Vector3;

use crate::aiding::innovation;
use crate::covariance::SparseRow;
use crate::filter::Filter;
use crate::params::EkfParams;
use crate::state::ATT;

/// Index of the rotation about NED down in the error state.
const YAW: usize = ATT + 2;

/// Predicted body field and the Jacobian entries (yaw column) for `filter`'s attitude.
fn predict(filter: &Filter, earth: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let r_t = filter.state.attitude.inverse();
    (r_t * earth, r_t * Vector3::new(earth.y, -earth.x, 0.0))
}

/// Innovations of the three axes of `measured` (gauss, body), gated at `mag_gate_sigma`.
pub fn field_innovations(
    filter: &Filter,
    measured: &Vector3<f64>,
    earth: &Vector3<f64>,
    params: &EkfParams,
) -> [Innovation; 3] {
    let r = params.mag_noise_gauss.powi(2);
    let (predicted, jacobian) = predict(filter, earth);
    std::array::from_fn(|axis| {
        let h = SparseRow::unit_scaled(YAW, jacobian[axis]);
        innovation(measured[axis] - predicted[axis], filter.innovation_variance(&h, r), params.mag_gate_sigma)
    })
}

/// Fuses the three axes one after the other (each against the state the previous left);
/// whether any was taken.
pub fn fuse_field(
    filter: &mut Filter,
    measured: &Vector3<f64>,
    earth: &Vector3<f64>,
    params: &EkfParams,
) -> bool {
    let r = params.mag_noise_gauss.powi(2);
    (0..3).fold(false, |fused, axis| {
        let (predicted, jacobian) = predict(filter, earth);
        let h = SparseRow::unit_scaled(YAW, jacobian[axis]);
        filter.fuse(&h, measured[axis] - predicted[axis], r) | fused
    })
}
