//! Seeded Gaussian noise and random walks.

use nalgebra::Vector3;
use rand::Rng;
use rand_distr::StandardNormal;
use rand_pcg::Pcg64;

/// Independent random streams of one simulation: every consumer gets its own, derived from the
/// run's seed, so adding draws to one does not shift the others.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Stream {
    Wind = 1,
    Imu,
    Gps,
    Baro,
    Mag,
    /// The second IMU (`[sensors.imu2]`): after the first five, so they stay as they were.
    Imu2,
    /// The rangefinders (`[sensors.rangefinder_up]`, `[sensors.rangefinder_down]`): last, so
    /// the other streams stay as they were.
    RangefinderUp,
    RangefinderDown,
}

/// The generator for `stream` of the run seeded with `seed`.
pub(crate) fn rng(seed: u64, stream: Stream) -> Pcg64 {
    let state = (u128::from(seed) << 64) | 0x853c_49e6_748f_ea9b;
    Pcg64::new(state, stream as u128)
}

pub(crate) fn standard_normal(rng: &mut Pcg64) -> f64 {
    rng.sample(StandardNormal)
}

pub(crate) fn standard_normal3(rng: &mut Pcg64) -> Vector3<f64> {
    Vector3::new(standard_normal(rng), standard_normal(rng), standard_normal(rng))
}

/// A three-axis random walk (a sensor bias): the value grows by `std_per_sqrt_s·√dt·N(0,1)`
/// per step.
#[derive(Clone, Debug)]
pub(crate) struct RandomWalk {
    pub(crate) value: Vector3<f64>,
    std_per_sqrt_s: f64,
}

impl RandomWalk {
    pub(crate) fn new(initial: [f64; 3], std_per_sqrt_s: f64) -> RandomWalk {
        RandomWalk { value: Vector3::from(initial), std_per_sqrt_s }
    }

    pub(crate) fn advance(&mut self, dt_s: f64, rng: &mut Pcg64) -> Vector3<f64> {
        if self.std_per_sqrt_s > 0.0 {
            self.value += standard_normal3(rng) * (self.std_per_sqrt_s * dt_s.sqrt());
        }
        self.value
    }
}
