//! Physical constants every crate shares, so that the simulator, the estimator, the controller
//! and the drivers agree to the last bit on what "1 g" is.

/// Standard gravity (m/s², CGPM 1901), the magnitude of gravity along NED down. The estimator,
/// the controller and the simulator all use it, so a hover in the simulator is a hover to the
/// controller; IMU datasheets scale "g" with it too.
pub const GRAVITY_M_S2: f64 = 9.80665;
