//! The output predictor: carries the delayed estimate to the present at IMU rate (PX4 EKF2's
//! `output_predictor`).
//!
//! It integrates every IMU sample as it arrives with the filter's latest biases and keeps its
//! past outputs in a ring buffer. Each time the filter advances its delayed horizon, the output
//! recorded at that same instant is compared with the filter state: the attitude error is fed
//! back as a small rotation per step with a gain that keeps the loop damped across the delay,
//! and velocity and position errors through a PI law whose correction is applied to the whole
//! buffer, so the fed-back error is not seen twice.

use nalgebra::{UnitQuaternion, Vector3};

use crate::delay_buffer::DelayBuffer;
use crate::filter::ResetDelta;
use crate::state::{ImuDelta, State};
use kestrel_proto::Time;
use kestrel_proto::units::GRAVITY_M_S2;

/// One output state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OutputSample {
    pub time: Time,
    /// Rotation from body FRD to NED.
    pub attitude: UnitQuaternion<f64>,
    /// Velocity north, east, down (m/s).
    pub vel_ned_m_s: Vector3<f64>,
    /// Position north, east, down (m).
    pub pos_ned_m: Vector3<f64>,
}

/// The present-time estimate.
#[derive(Debug)]
pub struct OutputPredictor {
    current: OutputSample,
    history: DelayBuffer<OutputSample>,
    /// NED rotation vector applied at each step to pull the attitude towards the filter's (rad).
    att_correction_rad: Vector3<f64>,
    vel_error_integral: Vector3<f64>,
    pos_error_integral: Vector3<f64>,
    /// Delay between the present and the filter's horizon (s).
    horizon_s: f64,
    /// Velocity and position tracking time constant (s).
    tau_s: f64,
}

impl Clone for OutputPredictor {
    fn clone(&self) -> Self {
        let OutputPredictor {
            current,
            history,
            att_correction_rad,
            vel_error_integral,
            pos_error_integral,
            horizon_s,
            tau_s,
        } = self;
        OutputPredictor {
            current: *current,
            history: history.clone(),
            att_correction_rad: *att_correction_rad,
            vel_error_integral: *vel_error_integral,
            pos_error_integral: *pos_error_integral,
            horizon_s: *horizon_s,
            tau_s: *tau_s,
        }
    }

    /// Copies into this predictor's history buffer instead of a new one.
    fn clone_from(&mut self, source: &Self) {
        let OutputPredictor {
            current,
            history,
            att_correction_rad,
            vel_error_integral,
            pos_error_integral,
            horizon_s,
            tau_s,
        } = source;
        self.current = *current;
        self.history.clone_from(history);
        self.att_correction_rad = *att_correction_rad;
        self.vel_error_integral = *vel_error_integral;
        self.pos_error_integral = *pos_error_integral;
        self.horizon_s = *horizon_s;
        self.tau_s = *tau_s;
    }
}

impl OutputPredictor {
    /// A predictor whose history holds `capacity` samples, starting at `state`.
    pub fn new(state: &State, capacity: usize, horizon_s: f64, tau_s: f64) -> OutputPredictor {
        let current = OutputSample {
            time: state.time,
            attitude: state.attitude,
            vel_ned_m_s: state.vel_ned_m_s,
            pos_ned_m: state.pos_ned_m,
        };
        let mut history = DelayBuffer::new(capacity);
        history.push(current);
        OutputPredictor {
            current,
            history,
            att_correction_rad: Vector3::zeros(),
            vel_error_integral: Vector3::zeros(),
            pos_error_integral: Vector3::zeros(),
            horizon_s,
            tau_s,
        }
    }

    /// The present estimate.
    pub fn current(&self) -> &OutputSample {
        &self.current
    }

    /// Integrates one IMU sample with the filter's biases.
    pub fn predict(
        &mut self,
        imu: &ImuDelta,
        gyro_bias_rad_s: &Vector3<f64>,
        accel_bias_m_s2: &Vector3<f64>,
    ) {
        let dt = imu.dt_s;
        let c = &mut self.current;
        let d_angle = imu.delta_angle_rad - gyro_bias_rad_s * dt;
        let d_vel = imu.delta_velocity_m_s - accel_bias_m_s2 * dt;
        let rotated = UnitQuaternion::from_scaled_axis(self.att_correction_rad)
            * c.attitude
            * UnitQuaternion::from_scaled_axis(d_angle);
        c.attitude = UnitQuaternion::new_normalize(rotated.into_inner());
        let vel = c.vel_ned_m_s + c.attitude * d_vel + Vector3::new(0.0, 0.0, GRAVITY_M_S2 * dt);
        c.pos_ned_m += (c.vel_ned_m_s + vel) * (0.5 * dt);
        c.vel_ned_m_s = vel;
        c.time = imu.time;
        self.history.push(*c);
    }

    /// Compares the output recorded at the filter's time with the filter state and updates the
    /// corrections; `dt_s` is the filter's step.
    pub fn correct(&mut self, filter: &State, dt_s: f64) {
        while self.history.pop_oldest_if(|o| o.time < filter.time).is_some() {}
        let Some(delayed) = self.history.oldest().copied() else { return };
        if delayed.time != filter.time {
            return;
        }
        let att_error = (filter.attitude * delayed.attitude.inverse()).scaled_axis();
        let att_gain = 0.5 * dt_s / self.horizon_s.max(dt_s);
        self.att_correction_rad = att_error * att_gain;

        let gain = dt_s / self.tau_s.max(dt_s);
        let vel_error = filter.vel_ned_m_s - delayed.vel_ned_m_s;
        let pos_error = filter.pos_ned_m - delayed.pos_ned_m;
        self.vel_error_integral += vel_error;
        self.pos_error_integral += pos_error;
        let vel_correction = vel_error * gain + self.vel_error_integral * (gain * gain * 0.1);
        let pos_correction = pos_error * gain + self.pos_error_integral * (gain * gain * 0.1);
        self.shift(&vel_correction, &pos_correction);
    }

    /// Copies a reset of the filter state into the present and the history (a yaw reset turns
    /// every stored attitude about NED down, so the comparison with the filter sees no jump).
    pub fn apply_reset(&mut self, reset: &ResetDelta) {
        self.shift(&reset.vel_ned_m_s, &reset.pos_ned_m);
        if reset.yaw_rad != 0.0 {
            let turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), reset.yaw_rad);
            for o in self.history.iter_mut() {
                o.attitude = turn * o.attitude;
            }
            self.current.attitude = turn * self.current.attitude;
        }
        if reset.pos_ned_m != Vector3::zeros() {
            self.pos_error_integral = Vector3::zeros();
        }
        if reset.vel_ned_m_s != Vector3::zeros() {
            self.vel_error_integral = Vector3::zeros();
        }
    }

    fn shift(&mut self, vel: &Vector3<f64>, pos: &Vector3<f64>) {
        for o in self.history.iter_mut() {
            o.vel_ned_m_s += vel;
            o.pos_ned_m += pos;
        }
        self.current.vel_ned_m_s += vel;
        self.current.pos_ned_m += pos;
    }
}
