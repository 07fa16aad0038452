//! In-flight yaw realignment (PX4 EKF2's in-flight yaw alignment, its magnetometer yaw reset
//! once the vehicle has climbed clear of the ground).
//!
//! Why: on the ground the magnetometer often reads the Earth's field plus a local one (steel in
//! the floor, the launch pad, a car). The alignment takes that sum as the Earth's field, and
//! magnetometer fusion on the ground then makes the wrong heading confident. In the air the
//! clean field disagrees with the reference by more than the gate, so fusion alone never
//! repairs it. Once, when the delayed state is `mag_yaw_reset_height_m` above the take-off point
//! (zero height is the alignment's barometric datum), the realignment averages the field for
//! [`WINDOW_S`], then resets yaw and the reference field from that average.
//!
//! Maths: each sample is rotated into NED with the filter's attitude at its time,
//! `m_i = R_i b_i`; with the filter's yaw off by `e`, the mean `m̄` points at declination `+ e`
//! (rotations during the window cancel, since each sample uses its own attitude). The reset
//! turns the attitude by `−e` about NED down and takes `R_z(−e) m̄` as the new reference field.
//! The new yaw variance is that of the mean's heading, `(σ_mag / |m̄_h|)² / N`, no smaller than
//! [`MIN_YAW_SD_RAD`]² (calibration and residual disturbances do not average out).

use kestrel_proto::Time;
use kestrel_proto::attitude::angle_difference_rad;
use kestrel_proto::messages::MagSample;
use nalgebra::{UnitQuaternion, Vector3};

use crate::filter::Filter;
use crate::params::EkfParams;

/// Length of the magnetometer average the realignment takes (s).
pub const WINDOW_S: f64 = 0.5;
/// Smallest yaw standard deviation the realignment claims (rad, ≈ 1.1°).
pub const MIN_YAW_SD_RAD: f64 = 0.02;

/// What the realignment found: the filter's yaw correction and the new reference field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct YawRealignment {
    /// Rotation to apply to the attitude about NED down (rad).
    pub yaw_change_rad: f64,
    /// Variance of the new yaw (rad²).
    pub variance_rad2: f64,
    /// The Earth's field in NED from then on (gauss).
    pub earth_ned_gauss: Vector3<f64>,
}

/// Waits for the height, averages the field over the window, realigns once.
#[derive(Clone, Debug, Default)]
pub struct InFlightYawAlignment {
    done: bool,
    /// Time of the first sample of the window.
    start: Option<Time>,
    /// Sum of the measured field rotated into NED with the filter's attitude (gauss).
    sum_ned_gauss: Vector3<f64>,
    count: u32,
}

impl InFlightYawAlignment {
    /// Takes a finite magnetometer sample with `filter` at its time; returns the realignment
    /// when the window above the height closes. Dropping below the height restarts the window.
    pub fn push(
        &mut self,
        filter: &Filter,
        sample: &MagSample,
        params: &EkfParams,
    ) -> Option<YawRealignment> {
        if self.done || !params.in_flight_yaw_reset {
            return None;
        }
        if -filter.state.pos_ned_m.z < params.mag_yaw_reset_height_m {
            *self = InFlightYawAlignment::default();
            return None;
        }
        let start = *self.start.get_or_insert(sample.time);
        self.sum_ned_gauss += filter.state.attitude * Vector3::from(sample.field_gauss);
        self.count += 1;
        if (sample.time - start).as_secs_f64() < WINDOW_S {
            return None;
        }
        self.done = true;
        let n = f64::from(self.count);
        let mean = self.sum_ned_gauss / n;
        let yaw_error = angle_difference_rad(mean.y.atan2(mean.x), params.mag_declination_deg.to_radians());
        let turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), -yaw_error);
        let heading_sd = params.mag_noise_gauss / mean.xy().norm();
        Some(YawRealignment {
            yaw_change_rad: -yaw_error,
            variance_rad2: (heading_sd * heading_sd / n).max(MIN_YAW_SD_RAD * MIN_YAW_SD_RAD),
            earth_ned_gauss: turn * mean,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::state::State;

    /// A vehicle turning at 1 rad/s at 2 m whose filter yaw is 0.4 rad too large: the
    /// realignment removes the 0.4 rad and recovers the field, whatever the true yaw did.
    #[test]
    fn recovers_the_yaw_error_of_a_turning_vehicle() {
        let params = EkfParams { mag_declination_deg: -2.0, ..EkfParams::default() };
        let dec = (-2.0f64).to_radians();
        let field = Vector3::new(0.4 * dec.cos(), 0.4 * dec.sin(), 0.1);
        let mut filter = Filter::aligned(State::at_rest(Time::ZERO, UnitQuaternion::identity()), true);
        let mut realign = InFlightYawAlignment::default();
        filter.state.pos_ned_m.z = -1.0;
        let sample = |t: f64, yaw: f64| {
            let truth = UnitQuaternion::from_euler_angles(0.05, -0.1, yaw);
            MagSample { time: Time::from_secs_f64(t), field_gauss: (truth.inverse() * field).into() }
        };
        let at = |t: f64| (t, UnitQuaternion::from_euler_angles(0.05, -0.1, t + 0.4));
        let (t, q) = at(0.0);
        filter.state.attitude = q;
        assert_eq!(realign.push(&filter, &sample(t, t), &params), None, "below the height");
        filter.state.pos_ned_m.z = -2.0;
        let mut found = None;
        for i in 0..=60 {
            let (t, q) = at(0.01 * f64::from(i));
            filter.state.attitude = q;
            found = found.or(realign.push(&filter, &sample(t, t), &params));
        }
        let r = found.expect("realigned after the window");
        assert!((r.yaw_change_rad + 0.4).abs() < 1e-9, "{r:?}");
        assert!((r.earth_ned_gauss - field).norm() < 1e-9, "{r:?}");
        assert_eq!(r.variance_rad2, MIN_YAW_SD_RAD * MIN_YAW_SD_RAD);
        assert_eq!(realign.push(&filter, &sample(1.0, 1.0), &params), None, "only once");
    }
}
