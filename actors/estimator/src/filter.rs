//! The filter at the delayed fusion horizon: nominal state, error covariance, the prediction
//! step (thesis eq. 3.5–3.19) and the correction primitives the aiding sources use.

use kestrel_proto::units::GRAVITY_M_S2;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use crate::covariance::{
    FusionFault, NotFinite, ProcessNoise, SparseRow, Transition, check_finite, fuse_scalar, reset_block,
};
use crate::state::{ACCEL_BIAS, ATT, Covariance, ERROR_STATES, GYRO_BIAS, ImuDelta, POS, State, VEL};

/// Initial standard deviations after alignment.
const INIT_TILT_RAD: f64 = 0.05;
const INIT_YAW_RAD: f64 = 0.15;
const INIT_VEL_M_S: f64 = 0.5;
const INIT_POS_M: f64 = 1.0;
const INIT_GYRO_BIAS_RAD_S: f64 = 0.01;
const INIT_ACCEL_BIAS_M_S2: f64 = 0.2;

/// Standard deviations after an IMU gap: seconds of flight on unknown rates and forces.
const IMU_GAP_TILT_RAD: f64 = 0.2;
const IMU_GAP_YAW_RAD: f64 = 0.5;
const IMU_GAP_VEL_M_S: f64 = 5.0;
const IMU_GAP_POS_M: f64 = 10.0;

/// Standard deviations after GPS velocity was rejected for too long: a bias step of up to
/// about 10°/s or 1 m/s² within 2σ.
const INERTIAL_RESET_TILT_RAD: f64 = 0.1;
const INERTIAL_RESET_GYRO_BIAS_RAD_S: f64 = 0.1;
const INERTIAL_RESET_ACCEL_BIAS_M_S2: f64 = 0.5;

/// Jumps of the state made by resets, which the output predictor must copy.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ResetDelta {
    pub pos_ned_m: Vector3<f64>,
    pub vel_ned_m_s: Vector3<f64>,
    /// Rotation of the attitude about NED down (rad), applied on the NED side.
    pub yaw_rad: f64,
}

/// State and covariance at the fusion horizon.
#[derive(Clone, Debug)]
pub struct Filter {
    pub state: State,
    pub cov: Covariance,
    /// Fusions refused for numerical reasons.
    pub numerical_faults: u32,
    /// Times the covariance was found not finite and reset to the initial uncertainty.
    pub covariance_resets: u32,
    /// Resets since the output predictor last took them.
    pending_reset: ResetDelta,
}

/// Propagates `state` over one IMU interval (eq. 3.6–3.11) and returns the new state with the
/// transition's Jacobian blocks.
///
/// The quaternion is integrated exactly for a constant rate over the step and renormalised; the
/// specific force is rotated with the attitude at the end of the step (where the IMU reports
/// it); position integrates the mean of the old and new velocity.
pub fn propagate(state: &State, imu: &ImuDelta) -> (State, Transition) {
    let dt = imu.dt_s;
    let d_angle = imu.delta_angle_rad - state.gyro_bias_rad_s * dt;
    let d_vel = imu.delta_velocity_m_s - state.accel_bias_m_s2 * dt;
    let attitude = UnitQuaternion::new_normalize(
        (state.attitude * UnitQuaternion::from_scaled_axis(d_angle)).into_inner(),
    );
    let r = attitude.to_rotation_matrix().into_inner();
    let r_dv = r * d_vel;
    let vel = state.vel_ned_m_s + r_dv + Vector3::new(0.0, 0.0, GRAVITY_M_S2 * dt);
    let pos = state.pos_ned_m + (state.vel_ned_m_s + vel) * (0.5 * dt);
    let next = State { time: imu.time, attitude, vel_ned_m_s: vel, pos_ned_m: pos, ..*state };
    let right_jacobian = Matrix3::identity() - d_angle.cross_matrix() * 0.5;
    (next, Transition { a: -r * right_jacobian * dt, b: -r_dv.cross_matrix(), c: -r * dt, dt_s: dt })
}

impl Filter {
    /// A filter just aligned at rest with `attitude`; `yaw_known` says whether a compass set the
    /// heading.
    pub fn aligned(state: State, yaw_known: bool) -> Filter {
        let yaw_sd = if yaw_known { INIT_YAW_RAD } else { 1.0 };
        Filter {
            state,
            cov: initial_covariance(yaw_sd),
            numerical_faults: 0,
            covariance_resets: 0,
            pending_reset: ResetDelta::default(),
        }
    }

    /// The prediction step: state and covariance over one IMU interval.
    pub fn predict(&mut self, imu: &ImuDelta, noise: &ProcessNoise) {
        let (next, transition) = propagate(&self.state, imu);
        self.state = next;
        if let Err(fault) = transition.predict(&mut self.cov, noise) {
            self.reset_covariance(fault);
        }
    }

    /// Replaces a covariance that is no longer finite by the initial uncertainty (yaw as after a
    /// compass alignment), keeping the state: a NaN anywhere would otherwise reach every gain.
    /// Counted and logged.
    fn reset_covariance(&mut self, fault: NotFinite) {
        tracing::warn!(time = %self.state.time, %fault, "covariance reset to the initial uncertainty");
        self.cov = initial_covariance(INIT_YAW_RAD);
        self.covariance_resets += 1;
    }

    /// Innovation variance of row `h` with observation variance `r`.
    pub fn innovation_variance(&self, h: &SparseRow, r: f64) -> f64 {
        h.innovation_variance(&self.cov, r)
    }

    /// Fuses one scalar observation with innovation `y` and observation variance `r` and
    /// injects the correction. Returns false (and counts a fault) when refused.
    pub fn fuse(&mut self, h: &SparseRow, y: f64, r: f64) -> bool {
        match fuse_scalar(&mut self.cov, h, y, r) {
            Ok(dx) => {
                let next = self.state.boxplus(&dx);
                if next.is_finite() {
                    self.state = next;
                    true
                } else {
                    self.numerical_faults += 1;
                    false
                }
            }
            Err(FusionFault::Covariance(fault)) => {
                self.numerical_faults += 1;
                self.reset_covariance(fault);
                false
            }
            Err(fault) => {
                tracing::debug!(%fault, "fusion refused");
                self.numerical_faults += 1;
                // A refusal that did not look at the covariance may leave a bad one in place.
                if let Err(fault) = check_finite(&self.cov) {
                    self.reset_covariance(fault);
                }
                false
            }
        }
    }

    /// Sets north/east position to `ne_m` with variance `variance_m2`, forgetting correlations.
    pub fn reset_horizontal_position(&mut self, ne_m: [f64; 2], variance_m2: f64) {
        let delta = Vector3::new(ne_m[0] - self.state.pos_ned_m.x, ne_m[1] - self.state.pos_ned_m.y, 0.0);
        self.state.pos_ned_m += delta;
        self.pending_reset.pos_ned_m += delta;
        reset_block(&mut self.cov, POS, 2, variance_m2);
    }

    /// Sets the down position to `down_m` with variance `variance_m2`, forgetting correlations
    /// (a height source switch or a rejection timeout).
    pub fn reset_vertical_position(&mut self, down_m: f64, variance_m2: f64) {
        let delta = down_m - self.state.pos_ned_m.z;
        self.state.pos_ned_m.z = down_m;
        self.pending_reset.pos_ned_m.z += delta;
        reset_block(&mut self.cov, POS + 2, 1, variance_m2);
    }

    /// After the IMU stream stopped and resumed at `time`: the state is taken to `time` as it
    /// was (there is nothing to predict with) and everything the gap made unknown gets back its
    /// initial uncertainty or more, with its correlations forgotten, so the aiding pulls the
    /// state in quickly instead of being gated out against a stale, confident one.
    pub fn resume_after_imu_gap(&mut self, time: kestrel_proto::Time) {
        self.state.time = time;
        reset_block(&mut self.cov, ATT, 2, IMU_GAP_TILT_RAD * IMU_GAP_TILT_RAD);
        reset_block(&mut self.cov, ATT + 2, 1, IMU_GAP_YAW_RAD * IMU_GAP_YAW_RAD);
        reset_block(&mut self.cov, VEL, 3, IMU_GAP_VEL_M_S * IMU_GAP_VEL_M_S);
        reset_block(&mut self.cov, POS, 3, IMU_GAP_POS_M * IMU_GAP_POS_M);
    }

    /// After GPS velocity could not be followed for long: the inertial prediction is what is
    /// wrong (a gyro or accelerometer bias step tilts it away), so tilt and both biases get back
    /// a large uncertainty, uncorrelated, and the GPS velocity fused next corrects them.
    pub fn raise_inertial_uncertainty(&mut self) {
        reset_block(&mut self.cov, ATT, 2, INERTIAL_RESET_TILT_RAD * INERTIAL_RESET_TILT_RAD);
        reset_block(&mut self.cov, GYRO_BIAS, 3, INERTIAL_RESET_GYRO_BIAS_RAD_S.powi(2));
        reset_block(&mut self.cov, ACCEL_BIAS, 3, INERTIAL_RESET_ACCEL_BIAS_M_S2.powi(2));
    }

    /// After a prediction over a clipped accelerometer sample: what the specific force did beyond
    /// full scale is unknown, so `variance_m2_s2` is added to each velocity axis's variance, and
    /// the aiding corrects the velocity within a few fixes instead of being outweighed by a
    /// confident prediction that understated the interval (a touchdown's spike).
    pub fn add_velocity_variance(&mut self, variance_m2_s2: f64) {
        for i in 0..3 {
            self.cov[(VEL + i, VEL + i)] += variance_m2_s2;
        }
    }

    /// After the prediction moved to another IMU: the bias states were the old IMU's, so they
    /// start again from zero with their initial uncertainty, uncorrelated.
    pub fn forget_imu_biases(&mut self) {
        self.state.gyro_bias_rad_s = Vector3::zeros();
        self.state.accel_bias_m_s2 = Vector3::zeros();
        reset_block(&mut self.cov, GYRO_BIAS, 3, INIT_GYRO_BIAS_RAD_S * INIT_GYRO_BIAS_RAD_S);
        reset_block(&mut self.cov, ACCEL_BIAS, 3, INIT_ACCEL_BIAS_M_S2 * INIT_ACCEL_BIAS_M_S2);
    }

    /// Whether the state and covariance are all finite.
    pub fn is_finite(&self) -> bool {
        let s = &self.state;
        let vectors = [s.vel_ned_m_s, s.pos_ned_m, s.gyro_bias_rad_s, s.accel_bias_m_s2];
        s.attitude.coords.iter().all(|x| x.is_finite())
            && vectors.iter().all(|v| v.iter().all(|x| x.is_finite()))
            && self.cov.iter().all(|x| x.is_finite())
    }

    /// Sets the NED velocity to `vel_ned_m_s` with variance `variance`, forgetting correlations.
    pub fn reset_velocity(&mut self, vel_ned_m_s: Vector3<f64>, variance: f64) {
        let delta = vel_ned_m_s - self.state.vel_ned_m_s;
        self.state.vel_ned_m_s = vel_ned_m_s;
        self.pending_reset.vel_ned_m_s += delta;
        reset_block(&mut self.cov, VEL, 3, variance);
    }

    /// Turns the attitude by `yaw_change_rad` about NED down and sets the yaw variance to
    /// `variance_rad2`, uncorrelated with every other state (a yaw reset to the magnetometer).
    ///
    /// The attitude error is a rotation vector in NED, so turning the nominal attitude turns the
    /// tilt error with it: `δθ' = R_z δθ` (`R_z` the reset's rotation), i.e. the attitude rows
    /// and columns of `P` are rotated. Then the down component, which the measurement replaced,
    /// forgets its correlations. Velocity and position are in NED and do not move.
    pub fn reset_yaw(&mut self, yaw_change_rad: f64, variance_rad2: f64) {
        let turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw_change_rad);
        self.state.attitude = turn * self.state.attitude;
        let mut t = Covariance::identity();
        t.fixed_view_mut::<3, 3>(ATT, ATT).copy_from(turn.to_rotation_matrix().matrix());
        self.cov = t * self.cov * t.transpose();
        reset_block(&mut self.cov, ATT + 2, 1, variance_rad2);
        self.pending_reset.yaw_rad += yaw_change_rad;
    }

    /// Takes the resets made since the last call.
    pub fn take_reset(&mut self) -> Option<ResetDelta> {
        let reset = std::mem::take(&mut self.pending_reset);
        (reset != ResetDelta::default()).then_some(reset)
    }

    /// Variances of the thesis's 16 states (quaternion w, x, y, z; velocity; position; gyro
    /// bias; accel bias), the quaternion's mapped from the attitude error through
    /// `∂q/∂δθ = ½ [−vᵀ; w·I − [v]×]` (v the quaternion's vector part).
    pub fn thesis_variances(&self) -> [f64; 16] {
        let q = self.state.attitude.quaternion();
        let v = q.imag();
        let mut j = nalgebra::SMatrix::<f64, 4, 3>::zeros();
        j.fixed_view_mut::<1, 3>(0, 0).copy_from(&(-v.transpose() * 0.5));
        j.fixed_view_mut::<3, 3>(1, 0).copy_from(&((Matrix3::identity() * q.w - v.cross_matrix()) * 0.5));
        let p_att = self.cov.fixed_view::<3, 3>(ATT, ATT);
        let p_q = j * p_att * j.transpose();
        let mut out = [0.0; 16];
        for (i, o) in out.iter_mut().take(4).enumerate() {
            *o = p_q[(i, i)];
        }
        for i in VEL..ERROR_STATES {
            out[i + 1] = self.cov[(i, i)];
        }
        out
    }
}

/// The covariance just after alignment, with yaw standard deviation `yaw_sd` (rad).
fn initial_covariance(yaw_sd: f64) -> Covariance {
    let mut cov = Covariance::zeros();
    let sds = [
        (ATT, [INIT_TILT_RAD, INIT_TILT_RAD, yaw_sd]),
        (VEL, [INIT_VEL_M_S; 3]),
        (POS, [INIT_POS_M; 3]),
        (GYRO_BIAS, [INIT_GYRO_BIAS_RAD_S; 3]),
        (ACCEL_BIAS, [INIT_ACCEL_BIAS_M_S2; 3]),
    ];
    for (start, sd) in sds {
        for (i, s) in sd.iter().enumerate() {
            cov[(start + i, start + i)] = s * s;
        }
    }
    cov
}

#[cfg(test)]
mod tests {
    use super::*;
    use kestrel_proto::Time;

    fn filter() -> Filter {
        Filter::aligned(State::at_rest(Time::ZERO, UnitQuaternion::identity()), true)
    }

    fn still(time_us: u64) -> ImuDelta {
        ImuDelta::from_rates(Time::from_micros(time_us), [0.0; 3], [0.0, 0.0, -GRAVITY_M_S2], 0.0025)
    }

    const NOISE: ProcessNoise =
        ProcessNoise { gyro_rad_s: 0.015, accel_m_s2: 0.25, gyro_bias_rad_s2: 1e-3, accel_bias_m_s3: 3e-3 };

    #[test]
    fn a_poisoned_covariance_is_reset_and_counted() {
        let mut f = filter();
        f.cov[(4, 10)] = f64::NAN;
        f.cov[(10, 4)] = f64::NAN;
        f.predict(&still(2500), &NOISE);
        assert_eq!(f.covariance_resets, 1);
        assert!(f.cov.iter().all(|x| x.is_finite()));
        assert!(f.fuse(&SparseRow::unit(VEL), 0.1, 0.25), "fusion works again after the reset");

        f.cov[(0, 1)] = f64::NAN;
        assert!(!f.fuse(&SparseRow::unit(POS), 0.1, 0.25), "a poisoned covariance is not fused with");
        assert_eq!((f.covariance_resets, f.numerical_faults), (2, 1));
        assert!(f.cov.iter().all(|x| x.is_finite()));
        assert!(f.state.is_finite());
    }

    #[test]
    fn a_yaw_reset_turns_the_tilt_errors_and_forgets_the_yaw_correlations() {
        let mut f = filter();
        f.cov[(ATT, ATT)] = 0.01;
        f.cov[(ATT + 1, ATT + 1)] = 0.04;
        f.cov[(ATT + 2, VEL)] = 0.003;
        f.cov[(VEL, ATT + 2)] = 0.003;
        f.reset_yaw(std::f64::consts::FRAC_PI_2, 0.02);
        let (_, _, yaw) = f.state.attitude.euler_angles();
        assert!((yaw - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        // A quarter turn about down carries the east tilt error to north and north to west.
        assert!((f.cov[(ATT, ATT)] - 0.04).abs() < 1e-12 && (f.cov[(ATT + 1, ATT + 1)] - 0.01).abs() < 1e-12);
        assert_eq!(f.cov[(ATT + 2, ATT + 2)], 0.02);
        assert!((0..ERROR_STATES).filter(|&j| j != ATT + 2).all(|j| f.cov[(ATT + 2, j)] == 0.0));
        assert_eq!(f.take_reset().map(|r| r.yaw_rad), Some(std::f64::consts::FRAC_PI_2));
    }
}
