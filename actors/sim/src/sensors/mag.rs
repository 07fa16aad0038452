//! The magnetometer: the Earth's field at home rotated into the sensor board, bent by soft iron
//! and offset by hard iron (the airframe's own iron and currents, fixed in the body), plus white
//! noise: `measured = soft_iron · (R_boardᵀ · field_body) + hard_iron_gauss + noise`, the model
//! `kestrel_proto::calibration::MagCalibration` undoes.

use kestrel_proto::Time;
use kestrel_proto::calibration::{MagCalibration, matrix3};
use kestrel_proto::messages::MagSample;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, finite, non_negative, rate};
use crate::rigid_body::RigidBodyState;
use crate::sensors::noise::standard_normal3;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MagParams {
    /// Sample rate (Hz).
    pub rate_hz: f64,
    /// Delay from measurement to delivery (s).
    pub lag_s: f64,
    /// 1σ white noise of each axis (gauss).
    pub noise_gauss: f64,
    /// Constant offset in board FRD from magnetised parts and currents (gauss).
    pub hard_iron_gauss: [f64; 3],
    /// Soft iron: how the airframe's iron bends and scales the field (rows: board FRD axes);
    /// identity for none. Positive determinant; a symmetric matrix is what a fit recovers.
    pub soft_iron: [[f64; 3]; 3],
}

impl Default for MagParams {
    /// The MPU-9250's AK8963 at 100 Hz.
    fn default() -> MagParams {
        MagParams {
            rate_hz: 100.0,
            lag_s: 0.0,
            noise_gauss: 0.005,
            hard_iron_gauss: [0.0; 3],
            soft_iron: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        }
    }
}

impl MagParams {
    pub(crate) fn validate(&self) -> Result<(), InvalidParam> {
        rate("rate_hz", self.rate_hz)?;
        non_negative("lag_s", self.lag_s)?;
        if self.lag_s > 10.0 {
            return Err(InvalidParam::new("lag_s", "must not exceed 10 s"));
        }
        non_negative("noise_gauss", self.noise_gauss)?;
        finite("hard_iron_gauss", &self.hard_iron_gauss)?;
        MagCalibration::new(self.hard_iron_gauss, self.soft_iron)
            .map(|_| ())
            .map_err(|e| InvalidParam::new("soft_iron", e.to_string()))
    }
}

/// What the active faults do to the magnetometer (see [`FaultKind`](crate::faults::FaultKind)).
#[derive(Clone, Debug, PartialEq)]
pub struct MagFaults {
    /// `mag_anomaly`: added to the reading (gauss, body FRD).
    pub added_frd_gauss: Vector3<f64>,
    /// `mag_stuck`: the last sample repeated.
    pub stuck: bool,
}

impl Default for MagFaults {
    fn default() -> MagFaults {
        MagFaults { added_frd_gauss: Vector3::zeros(), stuck: false }
    }
}

/// The magnetometer's random stream and its last sample.
#[derive(Clone, Debug)]
pub(crate) struct Mag {
    params: MagParams,
    soft_iron: Matrix3<f64>,
    /// Board → airframe, when the board is not aligned with it.
    board: Option<UnitQuaternion<f64>>,
    rng: Pcg64,
    last: Option<MagSample>,
}

impl Mag {
    pub(crate) fn new(params: &MagParams, board: Option<UnitQuaternion<f64>>, rng: Pcg64) -> Mag {
        Mag { params: params.clone(), soft_iron: matrix3(&params.soft_iron), board, rng, last: None }
    }

    /// A sample at `time` in the Earth field `field_ned_gauss`, as `faults` leave it. The noise
    /// is drawn whatever the faults, so the stream after a fault is the same as without.
    pub(crate) fn measure(
        &mut self,
        time: Time,
        state: &RigidBodyState,
        field_ned_gauss: &Vector3<f64>,
        faults: &MagFaults,
    ) -> MagSample {
        let field_body = state.attitude.inverse_transform_vector(field_ned_gauss);
        let field_board = match &self.board {
            None => field_body,
            Some(board) => board.inverse_transform_vector(&field_body),
        };
        let field = self.soft_iron * field_board
            + Vector3::from(self.params.hard_iron_gauss)
            + standard_normal3(&mut self.rng) * self.params.noise_gauss
            + faults.added_frd_gauss;
        match &self.last {
            Some(last) if faults.stuck => MagSample { time, ..last.clone() },
            _ => {
                let sample = MagSample { time, field_gauss: field.into() };
                self.last = Some(sample.clone());
                sample
            }
        }
    }
}
