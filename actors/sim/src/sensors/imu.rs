//! The inertial measurement unit: gyro and accelerometer in the sensor board's FRD, each with
//! white noise and a bias that random-walks; the accelerometer also with a fixed offset and
//! per-axis scale error (what six-orientation calibration removes).
//!
//! The board may sit rotated against the airframe (`[sensors] board_rotation_deg`): both
//! sensors then read the airframe's rate and specific force turned into the board's axes.
//! `measured_accel = accel_scale ⊙ (R_boardᵀ · true) + accel_offset_m_s2 + bias + noise`.
//!
//! The accelerometer reports the *specific force* averaged over the sample interval:
//! (Δv/Δt − g) rotated into the body, which is what a delta-velocity IMU integrates. At rest it
//! reads about `[0, 0, −9.81]`; in free fall it reads zero.

use kestrel_proto::Time;
use kestrel_proto::messages::ImuSample;
use nalgebra::{UnitQuaternion, Vector3};
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, finite, non_negative, positive};
use crate::rigid_body::RigidBodyState;
use crate::sensors::noise::{RandomWalk, standard_normal3};
use kestrel_proto::units::GRAVITY_M_S2;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ImuParams {
    /// Sample rate (Hz); the simulator's physics tick.
    pub rate_hz: f64,
    /// 1σ white noise of each gyro sample (rad/s).
    pub gyro_noise_rad_s: f64,
    /// 1σ white noise of each accelerometer sample (m/s²).
    pub accel_noise_m_s2: f64,
    /// Gyro bias random walk (rad/s per √s).
    pub gyro_bias_walk_rad_s_per_sqrt_s: f64,
    /// Accelerometer bias random walk (m/s² per √s).
    pub accel_bias_walk_m_s2_per_sqrt_s: f64,
    /// Gyro bias at start, body FRD (rad/s).
    pub gyro_bias_initial_rad_s: [f64; 3],
    /// Accelerometer bias at start, board FRD (m/s²).
    pub accel_bias_initial_m_s2: [f64; 3],
    /// Fixed accelerometer offset, board FRD (m/s²): what six-orientation calibration finds.
    pub accel_offset_m_s2: [f64; 3],
    /// Accelerometer reading per unit of true specific force, per board axis (1 = exact).
    pub accel_scale: [f64; 3],
    /// Full-scale range of each accelerometer axis (g, `kestrel_proto::units::GRAVITY_M_S2`): the `accel_clip` fault
    /// clamps the output there. The MPU-9250 offers ±2, 4, 8 and 16 g; flight stacks use 16.
    pub accel_full_scale_g: f64,
}

impl Default for ImuParams {
    /// MPU-9250 at 400 Hz with a ~100 Hz filter, plus some motor vibration on the accelerometer.
    fn default() -> ImuParams {
        ImuParams {
            rate_hz: 400.0,
            gyro_noise_rad_s: 0.003,
            accel_noise_m_s2: 0.05,
            gyro_bias_walk_rad_s_per_sqrt_s: 3e-5,
            accel_bias_walk_m_s2_per_sqrt_s: 3e-4,
            gyro_bias_initial_rad_s: [0.0; 3],
            accel_bias_initial_m_s2: [0.0; 3],
            accel_offset_m_s2: [0.0; 3],
            accel_scale: [1.0; 3],
            accel_full_scale_g: 16.0,
        }
    }
}

impl ImuParams {
    pub(crate) fn validate(&self) -> Result<(), InvalidParam> {
        positive("rate_hz", self.rate_hz)?;
        if self.rate_hz > 10_000.0 {
            return Err(InvalidParam::new("rate_hz", "must not exceed 10 kHz"));
        }
        non_negative("gyro_noise_rad_s", self.gyro_noise_rad_s)?;
        non_negative("accel_noise_m_s2", self.accel_noise_m_s2)?;
        non_negative("gyro_bias_walk_rad_s_per_sqrt_s", self.gyro_bias_walk_rad_s_per_sqrt_s)?;
        non_negative("accel_bias_walk_m_s2_per_sqrt_s", self.accel_bias_walk_m_s2_per_sqrt_s)?;
        finite("gyro_bias_initial_rad_s", &self.gyro_bias_initial_rad_s)?;
        finite("accel_bias_initial_m_s2", &self.accel_bias_initial_m_s2)?;
        finite("accel_offset_m_s2", &self.accel_offset_m_s2)?;
        if let Some(s) = self.accel_scale.iter().find(|s| !(0.5..=2.0).contains(*s)) {
            return Err(InvalidParam::new("accel_scale", format!("must lie within 0.5..=2, got {s}")));
        }
        positive("accel_full_scale_g", self.accel_full_scale_g)
    }

    /// The accelerometer's full-scale range (m/s²).
    pub fn accel_full_scale_m_s2(&self) -> f64 {
        self.accel_full_scale_g * GRAVITY_M_S2
    }
}

/// What the active faults do to the IMU (see [`FaultKind`](crate::faults::FaultKind)).
#[derive(Clone, Debug, PartialEq)]
pub struct ImuFaults {
    /// `gyro_bias`: added to the gyro output (rad/s, body FRD).
    pub gyro_bias_rad_s: Vector3<f64>,
    /// `accel_bias`: added to the accelerometer output (m/s², body FRD).
    pub accel_bias_m_s2: Vector3<f64>,
    /// `accel_clip`: the accelerometer saturates at its full-scale range.
    pub clip: bool,
    /// `imu_stop`: no sample is published (the simulator drops it).
    pub stopped: bool,
}

impl Default for ImuFaults {
    fn default() -> ImuFaults {
        ImuFaults {
            gyro_bias_rad_s: Vector3::zeros(),
            accel_bias_m_s2: Vector3::zeros(),
            clip: false,
            stopped: false,
        }
    }
}

/// The IMU's state: its biases and random stream.
#[derive(Clone, Debug)]
pub(crate) struct Imu {
    params: ImuParams,
    /// Board → airframe, when the board is not aligned with it.
    board: Option<UnitQuaternion<f64>>,
    gyro_bias: RandomWalk,
    accel_bias: RandomWalk,
    rng: Pcg64,
}

impl Imu {
    pub(crate) fn new(params: &ImuParams, board: Option<UnitQuaternion<f64>>, rng: Pcg64) -> Imu {
        Imu {
            params: params.clone(),
            board,
            gyro_bias: RandomWalk::new(
                params.gyro_bias_initial_rad_s,
                params.gyro_bias_walk_rad_s_per_sqrt_s,
            ),
            accel_bias: RandomWalk::new(
                params.accel_bias_initial_m_s2,
                params.accel_bias_walk_m_s2_per_sqrt_s,
            ),
            rng,
        }
    }

    /// A sample at `time` covering the last `dt_s`, over which the mean acceleration was
    /// `accel_ned_m_s2`, as `faults` leave it (`faults.stopped` is the caller's: it drops the
    /// sample). The noise is drawn whatever the faults.
    pub(crate) fn measure(
        &mut self,
        time: Time,
        dt_s: f64,
        state: &RigidBodyState,
        accel_ned_m_s2: &Vector3<f64>,
        faults: &ImuFaults,
    ) -> ImuSample {
        let gyro_bias = self.gyro_bias.advance(dt_s, &mut self.rng);
        let accel_bias = self.accel_bias.advance(dt_s, &mut self.rng);
        let specific_force_ned = accel_ned_m_s2 - Vector3::new(0.0, 0.0, GRAVITY_M_S2);
        let specific_force_frd = state.attitude.inverse_transform_vector(&specific_force_ned);
        let (rate_board, force_board) = match &self.board {
            None => (state.angular_velocity_frd_rad_s, specific_force_frd),
            Some(board) => (
                board.inverse_transform_vector(&state.angular_velocity_frd_rad_s),
                board.inverse_transform_vector(&specific_force_frd),
            ),
        };
        let p = &self.params;
        let force_read =
            force_board.component_mul(&Vector3::from(p.accel_scale)) + Vector3::from(p.accel_offset_m_s2);
        let gyro = rate_board
            + gyro_bias
            + standard_normal3(&mut self.rng) * p.gyro_noise_rad_s
            + faults.gyro_bias_rad_s;
        let mut accel = force_read
            + accel_bias
            + standard_normal3(&mut self.rng) * p.accel_noise_m_s2
            + faults.accel_bias_m_s2;
        // Outside the `accel_clip` fault the simulated IMU does not saturate (ground-contact
        // spikes at touchdown exceed ±16 g and would need a softer contact model first).
        let mut accel_clipped = [false; 3];
        if faults.clip {
            let range = p.accel_full_scale_m_s2();
            for (axis, clipped) in accel.iter_mut().zip(&mut accel_clipped) {
                *clipped = axis.abs() >= range;
                *axis = axis.clamp(-range, range);
            }
        }
        ImuSample {
            time,
            gyro_rad_s: gyro.into(),
            accel_m_s2: accel.into(),
            dt_s,
            gyro_clipped: [false; 3],
            accel_clipped,
        }
    }
}
