//! Kestrel's state estimator: the thesis's 16-state extended Kalman filter (§3.1) done the way
//! PX4 EKF2 does it, and the actor that runs it.
//!
//! * [`Ekf`] is the pure core: feed it [`ImuSample`](kestrel_proto::messages::ImuSample)s and
//!   lagged GPS, barometer and magnetometer samples; read [`Ekf::nav_state`] and
//!   [`Ekf::status`].
//! * [`EstimatorActor`] is its actor shell.
//! * Replays of recorded flights (ULog, MCAP) live in the runtime (`kestrel::replay`), which
//!   feeds this core: the core never reads a file.
//!
//! Layout (after EKF2): `state` (what is estimated), `filter` (prediction, correction
//! primitives, resets), `covariance` (sparse `F P Fᵀ + G N Gᵀ`, scalar fusion, limits),
//! `delay_buffer`, `arrivals` (which lagged samples may enter it), `output_predictor`, `init`
//! (alignment), `imu_selection` (which of two IMUs is predicted from), `realign` (when a calibration change
//! makes it align again), `aiding::{gps, baro, mag, mag_yaw_reset}` (when to fuse each sensor and the
//! maths of its observation), `params`.

pub mod actor;
pub mod aiding;
pub mod arrivals;
pub mod covariance;
pub mod delay_buffer;
pub mod ekf;
pub mod error;
pub mod filter;
pub mod imu_selection;
pub mod init;
pub mod live_params;
pub mod output_predictor;
pub mod params;
pub mod realign;
pub mod state;

pub use actor::{EstimatorActor, EstimatorInput};
pub use ekf::Ekf;
pub use error::{InputError, ParamError};
pub use params::EkfParams;
