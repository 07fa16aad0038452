//! GPS, when to fuse (PX4 EKF2's `gps_control.cpp`): which fixes are used, the origin, and what
//! a glitch or a loss does.
//!
//! * A fix is used with a 3D fix, enough satellites and a sane accuracy. The first one sets the
//!   local NED origin; the origin's altitude is the mean, over the first
//!   [`ORIGIN_ALTITUDE_FIXES`] fixes, of GPS altitude plus the filter's height at each fix
//!   (heights come from the barometer, so this anchors them above sea level with the GPS noise
//!   averaged down). Only the geodetic anchor moves; local NED positions are untouched.
//! * Glitch: position (north and east together) and velocity (three axes together) are gated
//!   separately at `gps_gate_sigma`. A rejected position is dead reckoned on the velocity that
//!   still passes; a run of rejections longer than `gps_reset_timeout_s` (EKF2's
//!   `reset_timeout_max`, 7 s) resets to GPS, which by then is consistent with itself and not with
//!   the filter. A jump shorter than that is never followed. A reset that would move the
//!   position by more than `gps_reset_max_m` is not made: GPS is then consistent with itself and
//!   far from where the inertial navigation put the vehicle, and nothing on board says which is
//!   right; flying to a home kilometres away is worse than landing where the vehicle is. The
//!   refusal is reported ([`GpsControl::reset_refused`]) and the position reported invalid
//!   (the commander's estimator failsafe, `FS_EKF_ACTION`), while velocity, which did not jump,
//!   is still fused; GPS position back inside the gate is fused again. ArduPilot's analogue
//!   is `EK3_GLITCH_RAD` (25 m), the radius beyond which a GPS glitch is not followed at once;
//!   PX4 EKF2 resets after `reset_timeout_max` with no limit. Velocity does not jump when the
//!   receiver glitches: velocity the filter cannot follow for `gps_velocity_reset_timeout_s`
//!   means the inertial prediction is wrong (a gyro or accelerometer bias step), so velocity is
//!   reset to GPS and tilt and biases made uncertain, for GPS velocity to correct them.
//! * Loss: nothing usable for `gps_timeout_s` and the source is lost; the position is dead
//!   reckoned (and reported invalid once horizontal aiding has been gone for
//!   `horizontal_position_timeout_s`, see [`crate::ekf`]); the first usable fix after the loss
//!   resets position and velocity to GPS.

use kestrel_proto::Time;
use kestrel_proto::geo::{Geodetic, LocalFrame};
use kestrel_proto::messages::{AidingCounters, GpsFix, GpsFixType, Innovation};

use crate::aiding::gps::{self, GpsObservation};
use crate::aiding::{RejectionRun, Verdict, passes, recent};
use crate::filter::Filter;
use crate::params::EkfParams;

/// Fixes averaged into the origin's altitude (10 s at 5 Hz).
pub const ORIGIN_ALTITUDE_FIXES: u32 = 50;

/// GPS fusion state.
#[derive(Clone, Debug, Default)]
pub struct GpsControl {
    /// Sum of GPS altitude plus filter height over the fixes averaged so far, and their count.
    origin_altitude: (f64, u32),
    last_position_fused: Option<Time>,
    last_velocity_fused: Option<Time>,
    position_run: RejectionRun,
    velocity_run: RejectionRun,
    /// The newest usable fix in the local frame, for the barometer's check against GPS height.
    pub newest: Option<(Time, GpsObservation)>,
    /// The horizontal distance (m) of the last position reset refused for being longer than
    /// `gps_reset_max_m`, while GPS position stays outside its gate.
    refused_reset_m: Option<f64>,
    pub counters: AidingCounters,
    pub position: [Innovation; 2],
    pub velocity: [Innovation; 3],
    pub height: Innovation,
}

impl GpsControl {
    /// Whether GPS position was fused within `gps_timeout_s` of `now`.
    pub fn position_aiding(&self, now: Time, params: &EkfParams) -> bool {
        recent(self.last_position_fused, now, params.gps_timeout_s)
    }

    /// Whether GPS velocity was fused within `gps_timeout_s` of `now`.
    pub fn velocity_aiding(&self, now: Time, params: &EkfParams) -> bool {
        recent(self.last_velocity_fused, now, params.gps_timeout_s)
    }

    /// Whether any horizontal GPS observation was fused within `timeout_s` of `now`.
    pub fn horizontal_aiding_within(&self, now: Time, timeout_s: f64) -> bool {
        recent(self.last_position_fused, now, timeout_s) || recent(self.last_velocity_fused, now, timeout_s)
    }

    /// The distance of a GPS position reset refused for exceeding `gps_reset_max_m` (m), while
    /// GPS position has not come back inside its gate: the position cannot be vouched for.
    pub fn reset_refused(&self) -> Option<f64> {
        self.refused_reset_m
    }

    /// Forgets the fusion history, so that the next usable fix resets position and velocity
    /// (after the filter lost its IMU and its dead reckoning cannot be trusted).
    pub fn force_reset(&mut self) {
        self.last_position_fused = None;
        self.last_velocity_fused = None;
    }

    /// Fuses `fix` into `filter` (both at the fix's time); sets `frame` from the first good fix.
    /// `fuse_height`: the height source is GPS (the barometer has failed).
    pub fn fuse(
        &mut self,
        filter: &mut Filter,
        fix: &GpsFix,
        frame: &mut Option<LocalFrame>,
        params: &EkfParams,
        fuse_height: bool,
    ) {
        if !usable(fix, params) {
            return;
        }
        let now = filter.state.time;
        let geodetic = Geodetic { lat_deg: fix.lat_deg, lon_deg: fix.lon_deg, alt_m: fix.alt_msl_m };
        let Some(local) = frame else {
            let origin = Geodetic { alt_m: fix.alt_msl_m + filter.state.pos_ned_m.z, ..geodetic };
            self.origin_altitude = (origin.alt_m, 1);
            *frame = Some(LocalFrame::new(origin));
            let obs = GpsObservation::new(fix, [0.0, 0.0, filter.state.pos_ned_m.z], params);
            self.reset(filter, &obs, now);
            return;
        };
        if self.origin_altitude.1 < ORIGIN_ALTITUDE_FIXES {
            let (sum, n) = self.origin_altitude;
            self.origin_altitude = (sum + fix.alt_msl_m + filter.state.pos_ned_m.z, n + 1);
            let alt_m = self.origin_altitude.0 / f64::from(n + 1);
            *local = LocalFrame::new(Geodetic { alt_m, ..local.home() });
        }
        let obs = GpsObservation::new(fix, local.to_ned(geodetic), params);
        self.newest = Some((now, obs));
        if !self.horizontal_aiding_within(now, params.gps_timeout_s) {
            tracing::info!(time = %now, "GPS resumed after a loss: resetting position and velocity");
            self.reset(filter, &obs, now);
            return;
        }
        let gate = params.gps_gate_sigma;
        let timeout_s = params.gps_reset_timeout_s;
        let mut rejected = false;
        let mut fused = false;

        self.velocity = gps::velocity_innovations(filter, &obs, gate);
        match self.velocity_run.judge(now, passes(&self.velocity), params.gps_velocity_reset_timeout_s) {
            Verdict::Fuse => {
                fused |= gps::fuse_velocity(filter, &obs);
                self.last_velocity_fused = Some(now);
            }
            Verdict::Reject => rejected = true,
            Verdict::TimedOut => {
                tracing::warn!(
                    time = %now,
                    "GPS velocity rejected for too long: resetting to it, tilt and biases uncertain"
                );
                filter.reset_velocity(obs.vel_ned_m_s, obs.vel_var_m2_s2);
                filter.raise_inertial_uncertainty();
                self.counters.resets += 1;
                self.last_velocity_fused = Some(now);
            }
        }

        self.position = gps::position_innovations(filter, &obs, gate);
        match self.position_run.judge(now, passes(&self.position), timeout_s) {
            Verdict::Fuse => {
                fused |= gps::fuse_position(filter, &obs);
                self.last_position_fused = Some(now);
                if self.refused_reset_m.take().is_some() {
                    tracing::info!(time = %now, "GPS position inside its gate again: fused again");
                }
            }
            Verdict::Reject => rejected = true,
            Verdict::TimedOut if reset_distance_m(filter, &obs) > params.gps_reset_max_m => {
                let jump_m = reset_distance_m(filter, &obs);
                if self.refused_reset_m.is_none() {
                    tracing::warn!(
                        time = %now,
                        jump_m,
                        limit_m = params.gps_reset_max_m,
                        "GPS position rejected for too long, but a reset would move it too far: refused"
                    );
                }
                self.refused_reset_m = Some(jump_m);
                rejected = true;
            }
            Verdict::TimedOut => {
                tracing::warn!(time = %now, "GPS position rejected for too long: resetting to GPS");
                filter.reset_horizontal_position([obs.pos_ned_m.x, obs.pos_ned_m.y], obs.pos_var_m2);
                self.counters.resets += 1;
                self.last_position_fused = Some(now);
                self.refused_reset_m = None;
            }
        }

        if fuse_height {
            self.height = gps::height_innovation(filter, &obs, gate);
            if self.height.test_ratio <= 1.0 {
                fused |= gps::fuse_height(filter, &obs);
            } else {
                rejected = true;
            }
        }
        self.counters.fused += u64::from(fused);
        self.counters.rejected += u64::from(rejected);
    }

    fn reset(&mut self, filter: &mut Filter, obs: &GpsObservation, now: Time) {
        filter.reset_horizontal_position([obs.pos_ned_m.x, obs.pos_ned_m.y], obs.pos_var_m2);
        filter.reset_velocity(obs.vel_ned_m_s, obs.vel_var_m2_s2);
        self.counters.resets += 1;
        self.last_position_fused = Some(now);
        self.last_velocity_fused = Some(now);
        self.position_run.clear();
        self.velocity_run.clear();
        self.refused_reset_m = None;
    }
}

/// How far (m, horizontally) a reset to `obs` would move the position.
pub fn reset_distance_m(filter: &Filter, obs: &GpsObservation) -> f64 {
    (obs.pos_ned_m.xy() - filter.state.pos_ned_m.xy()).norm()
}

/// Whether a fix is good enough to use at all.
fn usable(fix: &GpsFix, params: &EkfParams) -> bool {
    fix.fix_type >= GpsFixType::Fix3d
        && fix.satellites >= params.gps_min_satellites
        && fix.h_acc_m <= params.gps_max_h_acc_m
        && [fix.lat_deg, fix.lon_deg, fix.alt_msl_m, fix.h_acc_m, fix.v_acc_m, fix.s_acc_m_s]
            .iter()
            .all(|x| x.is_finite())
        && fix.vel_ned_m_s.iter().all(|x| x.is_finite())
        && fix.lat_deg.abs() <= 90.0
        && fix.lon_deg.abs() <= 180.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::covariance::ProcessNoise;
    use crate::state::{ImuDelta, State};
    use kestrel_proto::units::GRAVITY_M_S2;
    use nalgebra::UnitQuaternion;
    use proptest::prelude::*;

    const HOME: Geodetic = Geodetic { lat_deg: 6.7971, lon_deg: 79.9017, alt_m: 20.0 };
    const NOISE: ProcessNoise =
        ProcessNoise { gyro_rad_s: 0.015, accel_m_s2: 0.25, gyro_bias_rad_s2: 1e-3, accel_bias_m_s3: 3e-3 };

    /// A vehicle at rest at home, its filter fed by a still IMU at 400 Hz and (when `fix_at`
    /// gives one) a GPS fix at 5 Hz reporting that NED position (m), for `seconds`.
    struct Bench {
        filter: Filter,
        gps: GpsControl,
        frame: Option<LocalFrame>,
        params: EkfParams,
        t_us: u64,
    }

    impl Bench {
        fn new() -> Bench {
            let filter = Filter::aligned(State::at_rest(Time::ZERO, UnitQuaternion::identity()), true);
            Bench { filter, gps: GpsControl::default(), frame: None, params: EkfParams::default(), t_us: 0 }
        }

        fn run(&mut self, seconds: f64, fix_at: impl Fn(f64) -> Option<[f64; 3]>) {
            let end = self.t_us + (seconds * 1e6) as u64;
            while self.t_us < end {
                self.t_us += 2500;
                let time = Time::from_micros(self.t_us);
                let imu = ImuDelta::from_rates(time, [0.0; 3], [0.0, 0.0, -GRAVITY_M_S2], 0.0025);
                self.filter.predict(&imu, &NOISE);
                if self.t_us.is_multiple_of(200_000)
                    && let Some(ned) = fix_at(time.as_secs_f64())
                {
                    let local = LocalFrame::new(HOME);
                    let p = local.to_geodetic(ned);
                    let fix = GpsFix {
                        time,
                        fix_type: GpsFixType::Fix3d,
                        satellites: 12,
                        lat_deg: p.lat_deg,
                        lon_deg: p.lon_deg,
                        alt_msl_m: p.alt_m,
                        vel_ned_m_s: [0.0; 3],
                        h_acc_m: 0.5,
                        v_acc_m: 0.8,
                        s_acc_m_s: 0.1,
                    };
                    self.gps.fuse(&mut self.filter, &fix, &mut self.frame, &self.params, false);
                }
            }
        }

        fn north_m(&self) -> f64 {
            self.filter.state.pos_ned_m.x
        }
    }

    #[test]
    fn a_50_m_jump_shorter_than_the_reset_timeout_is_rejected_and_never_followed() {
        let mut b = Bench::new();
        b.run(10.0, |_| Some([0.0; 3]));
        let before = b.gps.counters;
        b.run(5.0, |_| Some([50.0, 0.0, 0.0]));
        assert!(b.north_m().abs() < 0.5, "followed the jump to {} m", b.north_m());
        assert!(
            b.gps.position_aiding(b.filter.state.time, &b.params)
                || b.gps.velocity_aiding(b.filter.state.time, &b.params)
        );
        assert_eq!(b.gps.counters.resets, before.resets, "no reset");
        assert!(b.gps.counters.rejected >= before.rejected + 24, "{:?}", b.gps.counters);
        b.run(5.0, |_| Some([0.0; 3]));
        assert!(b.north_m().abs() < 0.5);
        assert!(b.gps.position_aiding(b.filter.state.time, &b.params), "fusing again after the jump");
    }

    #[test]
    fn a_jump_within_the_reset_limit_that_stays_past_the_reset_timeout_is_taken_once() {
        let mut b = Bench::new();
        b.run(10.0, |_| Some([0.0; 3]));
        let resets = b.gps.counters.resets;
        assert!(30.0 < b.params.gps_reset_max_m);
        b.run(6.9, |_| Some([30.0, 0.0, 0.0]));
        assert!(b.north_m().abs() < 0.5, "before the timeout: {} m", b.north_m());
        b.run(1.0, |_| Some([30.0, 0.0, 0.0]));
        assert!((b.north_m() - 30.0).abs() < 1.0, "after the timeout: {} m", b.north_m());
        assert_eq!(b.gps.counters.resets, resets + 1);
        assert_eq!(b.gps.reset_refused(), None);
        b.run(5.0, |_| Some([30.0, 0.0, 0.0]));
        assert_eq!(b.gps.counters.resets, resets + 1, "consistent again: fused, not reset");
    }

    #[test]
    fn a_2_km_offset_held_is_refused_reported_and_never_followed_until_gps_comes_back() {
        let mut b = Bench::new();
        b.run(10.0, |_| Some([0.0; 3]));
        let resets = b.gps.counters.resets;
        b.run(6.9, |_| Some([2000.0, 0.0, 0.0]));
        assert_eq!(b.gps.reset_refused(), None, "not before the reset timeout");
        b.run(30.0, |_| Some([2000.0, 0.0, 0.0]));
        assert!(b.north_m().abs() < 0.5, "followed the offset to {} m", b.north_m());
        assert_eq!(b.gps.counters.resets, resets, "no reset");
        let refused = b.gps.reset_refused().expect("the reset was refused and is reported");
        assert!((refused - 2000.0).abs() < 1.0, "{refused} m");
        let now = b.filter.state.time;
        assert!(!b.gps.position_aiding(now, &b.params), "GPS position not fused");
        assert!(b.gps.velocity_aiding(now, &b.params), "GPS velocity, which did not jump, still fused");
        // GPS back where the vehicle is: fused again, the refusal over.
        b.run(1.0, |_| Some([0.0; 3]));
        assert_eq!(b.gps.reset_refused(), None);
        assert!(b.gps.position_aiding(b.filter.state.time, &b.params));
    }

    #[test]
    fn the_reset_limit_is_a_live_parameter_a_refusal_honours_at_the_next_timeout() {
        let mut b = Bench::new();
        b.run(10.0, |_| Some([0.0; 3]));
        b.params.gps_reset_max_m = 20.0;
        b.run(7.4, |_| Some([30.0, 0.0, 0.0]));
        assert!(b.gps.reset_refused().is_some_and(|m| (m - 30.0).abs() < 1.0));
        assert!(b.north_m().abs() < 0.5);
        // Raised past the offset: the next timeout (7 s on) takes it.
        b.params.gps_reset_max_m = 50.0;
        b.run(7.4, |_| Some([30.0, 0.0, 0.0]));
        assert_eq!(b.gps.reset_refused(), None);
        assert!((b.north_m() - 30.0).abs() < 1.0, "{} m", b.north_m());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(16))]

        /// A GPS step longer than the reset limit, in any direction and held for any time,
        /// never moves the estimate of a still vehicle by more than the limit.
        #[test]
        fn a_step_beyond_the_limit_never_moves_the_estimate_by_more_than_the_limit(
            length_m in 51.0f64..5000.0,
            bearing_rad in 0.0f64..std::f64::consts::TAU,
            held_s in 6.0f64..25.0,
        ) {
            let mut b = Bench::new();
            b.run(10.0, |_| Some([0.0; 3]));
            let before = b.filter.state.pos_ned_m.xy();
            let step = [length_m * bearing_rad.cos(), length_m * bearing_rad.sin(), 0.0];
            let mut worst_m = 0.0f64;
            let halves = (held_s / 0.5) as usize;
            for _ in 0..halves {
                b.run(0.5, |_| Some(step));
                worst_m = worst_m.max((b.filter.state.pos_ned_m.xy() - before).norm());
            }
            prop_assert!(worst_m <= b.params.gps_reset_max_m, "moved {} m", worst_m);
            // Refused from the fix past the reset timeout (the first rejected fix 0.2 s in).
            let held = 0.5 * halves as f64;
            prop_assert_eq!(b.gps.reset_refused().is_some(), held > b.params.gps_reset_timeout_s + 0.2);
        }
    }

    #[test]
    fn a_loss_dead_reckons_then_the_first_fix_after_it_resets_position() {
        let mut b = Bench::new();
        b.run(10.0, |_| Some([0.0; 3]));
        let resets = b.gps.counters.resets;
        b.run(3.0, |_| None);
        let now = b.filter.state.time;
        assert!(!b.gps.horizontal_aiding_within(now, b.params.gps_timeout_s), "lost after gps_timeout_s");
        assert!(
            b.gps.horizontal_aiding_within(now, b.params.horizontal_position_timeout_s),
            "position still valid"
        );
        // The vehicle moved 20 m while GPS was gone: the first fix is taken whole.
        b.run(0.2, |_| Some([20.0, 0.0, 0.0]));
        assert!((b.north_m() - 20.0).abs() < 0.5, "{} m", b.north_m());
        assert_eq!(b.gps.counters.resets, resets + 1);
    }
}
