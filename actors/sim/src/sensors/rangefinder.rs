//! Single-beam rangefinders along the body's z axis (a Benewake TFmini Plus looking up or down):
//! the distance along the beam to the first surface of the world (the flat ground at down = 0,
//! `ground.rs`, or an obstacle), with white noise, as the sensor reports it: a surface nearer
//! than the minimum range reads the minimum, nothing within the maximum range reads nothing.
//!
//! The sensor sits at the vehicle's centre (no lever arm): landed, the downward one reads its
//! minimum. Its beam is a line; a TFmini's 3.6° cone is narrower than anything the worlds hold.

use kestrel_proto::Time;
use kestrel_proto::messages::{Obstacle, RangefinderOrientation, RangefinderSample};
use nalgebra::Vector3;
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, non_negative, positive, rate};
use crate::obstacles::ObstacleGeometry;
use crate::rigid_body::RigidBodyState;
use crate::sensors::noise::standard_normal;
use crate::sensors::schedule::{Delayed, Periodic};

/// `[sensors.rangefinder_up]`, `[sensors.rangefinder_down]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RangefinderParams {
    /// Sample rate (Hz).
    pub rate_hz: f64,
    /// Delay from measurement to delivery (s).
    pub lag_s: f64,
    /// Shortest distance the sensor reports (m): a nearer surface reads this.
    pub min_range_m: f64,
    /// Longest distance the sensor reports (m): beyond it the sample carries no distance.
    pub max_range_m: f64,
    /// 1σ white noise of the distance (m).
    pub noise_m: f64,
}

impl Default for RangefinderParams {
    /// A Benewake TFmini Plus: 0.1–12 m, at its default 100 Hz frame rate (every fourth tick
    /// of the 400 Hz simulator, so exactly periodic), 1 cm noise (its datasheet gives ±5 cm
    /// accuracy below 6 m, mostly a fixed bias per surface; the sample-to-sample scatter is
    /// about 1 cm). No lag: it reports each frame as it is taken.
    fn default() -> RangefinderParams {
        RangefinderParams { rate_hz: 100.0, lag_s: 0.0, min_range_m: 0.1, max_range_m: 12.0, noise_m: 0.01 }
    }
}

impl RangefinderParams {
    pub(crate) fn validate(&self) -> Result<(), InvalidParam> {
        rate("rate_hz", self.rate_hz)?;
        non_negative("lag_s", self.lag_s)?;
        if self.lag_s > 10.0 {
            return Err(InvalidParam::new("lag_s", "must not exceed 10 s"));
        }
        non_negative("min_range_m", self.min_range_m)?;
        positive("max_range_m", self.max_range_m)?;
        if self.min_range_m >= self.max_range_m {
            return Err(InvalidParam::new(
                "min_range_m",
                format!("must be less than max_range_m ({} m), got {}", self.max_range_m, self.min_range_m),
            ));
        }
        non_negative("noise_m", self.noise_m)
    }
}

/// Distance along the ray from `origin_ned_m` in the unit direction `dir_ned` to the first
/// surface (m), the ground or an obstacle; 0 from inside one; `None` beyond `max_m`.
pub(crate) fn first_surface_m(
    obstacles: &[Obstacle],
    origin_ned_m: &Vector3<f64>,
    dir_ned: &Vector3<f64>,
    max_m: f64,
) -> Option<f64> {
    // The ground is the half-space down ≥ 0; only a beam pointing down can meet it.
    let ground = (dir_ned.z > 0.0).then(|| (-origin_ned_m.z).max(0.0) / dir_ned.z);
    obstacles
        .iter()
        .filter_map(|o| o.ray_hit_m(origin_ned_m, dir_ned))
        .chain(ground)
        .fold(None, |nearest: Option<f64>, t| Some(nearest.map_or(t, |n| n.min(t))))
        .filter(|&t| t <= max_m)
}

/// One rangefinder: its random stream, its schedule and the samples waiting out its lag.
#[derive(Clone, Debug)]
pub(crate) struct Rangefinder {
    orientation: RangefinderOrientation,
    params: RangefinderParams,
    rng: Pcg64,
    due: Periodic,
    pending: Delayed<RangefinderSample>,
}

impl Rangefinder {
    /// A rangefinder looking along `orientation`, sampling one period after `start`.
    pub(crate) fn new(
        orientation: RangefinderOrientation,
        params: &RangefinderParams,
        rng: Pcg64,
        start: Time,
    ) -> Rangefinder {
        Rangefinder {
            orientation,
            params: params.clone(),
            rng,
            due: Periodic::new(params.rate_hz, start),
            pending: Delayed::new(params.lag_s, params.rate_hz),
        }
    }

    /// At tick `now`: measures if a sample is due, then hands every sample whose lag has
    /// passed to `release`, oldest first.
    pub(crate) fn step(
        &mut self,
        now: Time,
        state: &RigidBodyState,
        obstacles: &[Obstacle],
        release: impl FnMut(RangefinderSample),
    ) {
        if self.due.due(now) {
            let sample = self.measure(now, state, obstacles);
            self.pending.push(now, sample);
        }
        self.pending.release(now, release);
    }

    /// A sample at `time` from the vehicle in `state`. The noise is drawn whatever the beam
    /// meets, so the stream does not depend on the world.
    pub(crate) fn measure(
        &mut self,
        time: Time,
        state: &RigidBodyState,
        obstacles: &[Obstacle],
    ) -> RangefinderSample {
        let (min, max) = (self.params.min_range_m, self.params.max_range_m);
        let dir_ned = state.attitude * Vector3::from(self.orientation.body_axis());
        let noise_m = standard_normal(&mut self.rng) * self.params.noise_m;
        let distance_m = first_surface_m(obstacles, &state.position_ned_m, &dir_ned, max)
            .map(|true_m| (true_m.max(min) + noise_m).clamp(min, max));
        RangefinderSample {
            time,
            orientation: self.orientation,
            distance_m,
            min_range_m: min,
            max_range_m: max,
        }
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::UnitQuaternion;
    use proptest::prelude::*;

    use super::*;
    use crate::sensors::noise::{Stream, rng};

    /// A noiseless TFmini Plus looking `orientation`.
    fn exact(orientation: RangefinderOrientation) -> Rangefinder {
        let params = RangefinderParams { noise_m: 0.0, ..RangefinderParams::default() };
        Rangefinder::new(orientation, &params, rng(1, Stream::RangefinderUp), Time::ZERO)
    }

    fn at(position_ned_m: [f64; 3], roll_deg: f64, pitch_deg: f64) -> RigidBodyState {
        RigidBodyState {
            position_ned_m: Vector3::from(position_ned_m),
            attitude: UnitQuaternion::from_euler_angles(roll_deg.to_radians(), pitch_deg.to_radians(), 0.3),
            ..RigidBodyState::default()
        }
    }

    fn distance(sensor: &mut Rangefinder, state: &RigidBodyState, world: &[Obstacle]) -> Option<f64> {
        sensor.measure(Time::ZERO, state, world).distance_m
    }

    /// `got` is `want_m` but for rounding in the attitude's rotation.
    fn assert_reads(got: Option<f64>, want_m: f64) {
        assert!(got.is_some_and(|d| (d - want_m).abs() < 1e-9), "read {got:?}, expected {want_m} m");
    }

    /// A 20 m square slab, 1 m thick, its underside `down_m` below home.
    fn ceiling(down_m: f64) -> Obstacle {
        Obstacle::Box { center_ned_m: [0.0, 0.0, down_m - 0.5], size_m: [20.0, 20.0, 1.0], yaw_deg: 0.0 }
    }

    #[test]
    fn a_box_overhead_reads_the_gap_to_its_underside_within_the_noise() {
        // Vehicle at 2 m, a box's underside at 7 m: 5 m up.
        let world = [ceiling(-7.0)];
        let mut noisy = Rangefinder::new(
            RangefinderOrientation::Up,
            &RangefinderParams::default(),
            rng(3, Stream::RangefinderUp),
            Time::ZERO,
        );
        for _ in 0..100 {
            let d = distance(&mut noisy, &at([0.0, 0.0, -2.0], 0.0, 0.0), &world).expect("in range");
            assert!((d - 5.0).abs() < 0.05, "{d}: 5σ of 1 cm");
        }
        let d = distance(&mut exact(RangefinderOrientation::Up), &at([0.0, 0.0, -2.0], 0.0, 0.0), &world);
        assert_reads(d, 5.0);
    }

    #[test]
    fn a_tilted_beam_reads_the_gap_over_the_cosine_of_the_tilt() {
        let world = [ceiling(-7.0)];
        let mut up = exact(RangefinderOrientation::Up);
        for (roll, pitch) in [(20.0, 0.0), (0.0, -35.0), (25.0, 25.0)] {
            let state = at([1.0, -2.0, -2.0], roll, pitch);
            // The body's z axis against the vertical: cos(tilt) = cos(roll)·cos(pitch).
            let cos_tilt = f64::cos(f64::to_radians(roll)) * f64::cos(f64::to_radians(pitch));
            let d = distance(&mut up, &state, &world).expect("in range");
            assert!((d - 5.0 / cos_tilt).abs() < 1e-9, "{roll} {pitch}: {d}");
        }
    }

    #[test]
    fn the_ground_below_reads_the_height() {
        let mut down = exact(RangefinderOrientation::Down);
        for h in [0.5, 3.0, 11.5] {
            assert_reads(distance(&mut down, &at([4.0, 5.0, -h], 0.0, 0.0), &[]), h);
        }
        // Landed: the ground is nearer than the minimum range, which it reads.
        assert_reads(distance(&mut down, &at([0.0, 0.0, 0.0], 0.0, 0.0), &[]), 0.1);
        let tilted = distance(&mut down, &at([0.0, 0.0, -6.0], 30.0, 0.0), &[]).expect("in range");
        assert!((tilted - 6.0 / 30f64.to_radians().cos()).abs() < 1e-9, "{tilted}");
    }

    #[test]
    fn nothing_within_range_reads_no_distance() {
        let tree = Obstacle::Cylinder { base_ne_m: [0.0, 0.0], radius_m: 0.5, height_m: 5.0 };
        // Open sky, ground 20 m below, a tree's top 13 m below, a tree beside the beam.
        assert_eq!(
            distance(&mut exact(RangefinderOrientation::Up), &at([0.0, 0.0, -3.0], 0.0, 0.0), &[]),
            None
        );
        assert_eq!(
            distance(&mut exact(RangefinderOrientation::Down), &at([5.0, 0.0, -20.0], 0.0, 0.0), &[]),
            None
        );
        let above_tree = at([0.0, 0.0, -18.0], 0.0, 0.0);
        assert_eq!(
            distance(&mut exact(RangefinderOrientation::Down), &above_tree, std::slice::from_ref(&tree)),
            None
        );
        let beside = at([0.0, 0.6, -3.0], 0.0, 0.0);
        assert_eq!(distance(&mut exact(RangefinderOrientation::Up), &beside, &[tree]), None);
        // Beyond the maximum by a millimetre.
        assert_eq!(
            distance(
                &mut exact(RangefinderOrientation::Up),
                &at([0.0, 0.0, -2.0], 0.0, 0.0),
                &[ceiling(-14.001)]
            ),
            None
        );
    }

    #[test]
    fn a_cylinder_top_under_the_vehicle_reads_the_gap_to_it() {
        let tree = Obstacle::Cylinder { base_ne_m: [10.0, -3.0], radius_m: 0.4, height_m: 8.0 };
        let mut down = exact(RangefinderOrientation::Down);
        // 0.3 m off the axis, 11 m up: 3 m above an 8 m trunk.
        let d = distance(&mut down, &at([10.3, -3.0, -11.0], 0.0, 0.0), std::slice::from_ref(&tree));
        assert_reads(d, 3.0);
        // Just off its rim the ground, 11 m down, answers instead.
        assert_reads(distance(&mut down, &at([10.41, -3.0, -11.0], 0.0, 0.0), &[tree]), 11.0);
    }

    #[test]
    fn a_floating_box_is_met_from_below_and_from_above() {
        // A 2 m cube floating with its underside 4 m and its top 6 m above the ground, yawed.
        let cube = Obstacle::Box { center_ned_m: [0.0, 0.0, -5.0], size_m: [2.0, 2.0, 2.0], yaw_deg: 30.0 };
        let world = [cube];
        let up = distance(&mut exact(RangefinderOrientation::Up), &at([0.2, 0.1, -1.5], 0.0, 0.0), &world);
        assert_reads(up, 2.5);
        let down =
            distance(&mut exact(RangefinderOrientation::Down), &at([0.2, 0.1, -9.0], 0.0, 0.0), &world);
        assert_reads(down, 3.0);
        // Beside it (outside its yawed footprint) the ground answers, 1.5 m down.
        let beside =
            distance(&mut exact(RangefinderOrientation::Down), &at([0.0, 1.5, -1.5], 0.0, 0.0), &world);
        assert_reads(beside, 1.5);
    }

    #[test]
    fn the_noise_has_the_configured_spread_and_never_leaves_the_range() {
        let params = RangefinderParams { noise_m: 0.2, ..RangefinderParams::default() };
        let mut down = Rangefinder::new(
            RangefinderOrientation::Down,
            &params,
            rng(9, Stream::RangefinderDown),
            Time::ZERO,
        );
        let mid: Vec<f64> =
            (0..20_000).filter_map(|_| distance(&mut down, &at([0.0, 0.0, -6.0], 0.0, 0.0), &[])).collect();
        let mean = mid.iter().sum::<f64>() / mid.len() as f64;
        let std = (mid.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (mid.len() - 1) as f64).sqrt();
        assert!((mean - 6.0).abs() < 0.01 && (std / 0.2 - 1.0).abs() < 0.03, "{mean} {std}");
        for h in [0.0, 0.05, 11.9] {
            for _ in 0..1000 {
                let d = distance(&mut down, &at([0.0, 0.0, -h], 0.0, 0.0), &[]).expect("in range");
                assert!((0.1..=12.0).contains(&d), "{h}: {d}");
            }
        }
    }

    #[test]
    fn bad_params_name_their_field() {
        let bad = |p: RangefinderParams| p.validate().expect_err("refused").field;
        let good = RangefinderParams::default();
        assert_eq!(good.validate(), Ok(()));
        assert_eq!(bad(RangefinderParams { rate_hz: f64::NAN, ..good.clone() }), "rate_hz");
        assert_eq!(bad(RangefinderParams { rate_hz: 0.0, ..good.clone() }), "rate_hz");
        assert_eq!(bad(RangefinderParams { lag_s: -0.1, ..good.clone() }), "lag_s");
        assert_eq!(bad(RangefinderParams { min_range_m: -0.1, ..good.clone() }), "min_range_m");
        assert_eq!(bad(RangefinderParams { min_range_m: f64::NAN, ..good.clone() }), "min_range_m");
        assert_eq!(bad(RangefinderParams { max_range_m: f64::INFINITY, ..good.clone() }), "max_range_m");
        assert_eq!(bad(RangefinderParams { max_range_m: -1.0, ..good.clone() }), "max_range_m");
        assert_eq!(bad(RangefinderParams { min_range_m: 12.0, ..good.clone() }), "min_range_m");
        assert_eq!(bad(RangefinderParams { noise_m: f64::NEG_INFINITY, ..good.clone() }), "noise_m");
        assert_eq!(bad(RangefinderParams { noise_m: -0.01, ..good }), "noise_m");
    }

    /// One of the three shapes, within 15 m of home, standing on the ground or (boxes) floating.
    fn obstacle() -> impl Strategy<Value = Obstacle> {
        let box_ = (-15.0..15.0, -15.0..15.0, -12.0..-0.2, 0.2..6.0, 0.2..6.0, 0.2..6.0, -180.0..180.0)
            .prop_map(|(n, e, d, a, b, c, yaw_deg)| Obstacle::Box {
                center_ned_m: [n, e, d],
                size_m: [a, b, c],
                yaw_deg,
            });
        let cylinder =
            (-15.0..15.0, -15.0..15.0, 0.1..2.0, 0.5..15.0).prop_map(|(n, e, radius_m, height_m)| {
                Obstacle::Cylinder { base_ne_m: [n, e], radius_m, height_m }
            });
        let wall = (-15.0..15.0, -15.0..15.0, -15.0..15.0, -15.0..15.0, 0.5..10.0, 0.1..1.0).prop_map(
            |(n0, e0, dn, de, height_m, thickness_m)| Obstacle::Wall {
                from_ne_m: [n0, e0],
                to_ne_m: [n0 + dn + 0.5, e0 + de],
                height_m,
                thickness_m,
                textured: false,
            },
        );
        prop_oneof![box_, cylinder, wall]
    }

    /// How far `p` is from the nearest surface (m), signed: negative inside an obstacle or the ground.
    fn clearance_m(world: &[Obstacle], p: &Vector3<f64>) -> f64 {
        world.iter().map(|o| o.signed_distance_m(p)).fold(-p.z, f64::min)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]

        #[test]
        fn the_beam_stops_on_the_first_surface_and_the_reading_stays_within_range(
            world in prop::collection::vec(obstacle(), 0..6),
            position in (-12.0..12.0, -12.0..12.0, -14.0..0.0),
            attitude in (-180.0..180.0, -90.0..90.0, -180.0..180.0),
            looks_up in any::<bool>(),
            seed in any::<u64>(),
        ) {
            let origin = Vector3::new(position.0, position.1, position.2);
            let (roll, pitch, yaw): (f64, f64, f64) = attitude;
            let state = RigidBodyState {
                position_ned_m: origin,
                attitude: UnitQuaternion::from_euler_angles(roll.to_radians(), pitch.to_radians(), yaw.to_radians()),
                ..RigidBodyState::default()
            };
            let orientation = if looks_up { RangefinderOrientation::Up } else { RangefinderOrientation::Down };
            let params = RangefinderParams::default();
            let dir = state.attitude * Vector3::from(orientation.body_axis());
            let hit = first_surface_m(&world, &origin, &dir, params.max_range_m);
            // Nothing is met before the hit (or, without one, within the range): the sampled
            // points along the beam are all outside every surface.
            let clear_to = hit.unwrap_or(params.max_range_m);
            if clearance_m(&world, &origin) > 0.0 {
                for i in 0..400 {
                    let t = clear_to * f64::from(i) / 400.0;
                    let c = clearance_m(&world, &(origin + t * dir));
                    prop_assert!(c > -1e-7, "inside a surface at {t} m before the hit at {hit:?}: {c}");
                }
            }
            // The hit lies on a surface: an obstacle's or the ground's distance is zero there.
            if let Some(t) = hit {
                let p = origin + t * dir;
                let on_obstacle = world.iter().any(|o| o.signed_distance_m(&p).abs() < 1e-7);
                let on_ground = p.z.abs() < 1e-7;
                let inside = t == 0.0 && clearance_m(&world, &origin) <= 0.0;
                prop_assert!(on_obstacle || on_ground || inside, "{p:?} at {t} m lies on no surface");
            }
            let mut sensor = Rangefinder::new(orientation, &params, rng(seed, Stream::RangefinderDown), Time::ZERO);
            let sample = sensor.measure(Time::ZERO, &state, &world);
            prop_assert_eq!(sample.invalid(), None);
            prop_assert_eq!(sample.distance_m.is_some(), hit.is_some());
            if let Some(d) = sample.distance_m {
                prop_assert!((params.min_range_m..=params.max_range_m).contains(&d), "{d}");
            }
        }
    }
}
