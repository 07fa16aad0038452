//! Barometer, when to fuse, and the height source (PX4 EKF2's `baro_height_control.cpp` and
//! `gnss_height_control.cpp`, with the barometer as the height reference, `EKF2_HGT_REF` baro).
//!
//! * The alignment's mean pressure altitude fixes the offset between pressure altitude and the
//!   filter's height (the barometer observes height changes, not altitude above sea level);
//!   without a barometer during alignment the first sample after it does. Height and climb rate
//!   are gated at `baro_gate_sigma`.
//! * The barometer is found faulty only on its own evidence, never because GPS height moved:
//!   its height innovation (against the prediction) outside its gate for `baro_timeout_s`, as
//!   EKF2 stops baro fusion when its own fusion is failing and another height source works; or,
//!   when it and GPS height part, its height having moved away from the velocity-propagated
//!   height while GPS height did not. That height is GPS's Doppler vertical velocity
//!   integrated (the velocity that keeps the inertial prediction honest), independent of both
//!   heights: a GPS height step and a drifting barometer leave it alone. The filter's own
//!   vertical velocity will not do: fusing the barometer, it follows a drift in part.
//! * Each GPS fix compares the two: their difference, once its mean is learnt (the first
//!   [`AGREEMENT_FIXES`] fixes, then tracked with a [`AGREEMENT_TAU_FIXES`]-fix time constant
//!   while they agree), may not move by more than `baro_gps_tolerance_m` for longer than
//!   `baro_fault_timeout_s`. When it does, the source that moved away from the velocity height
//!   since they last agreed is the faulty one: a GPS height step leaves the barometer and the
//!   velocity height together, so GPS height is refused (never fused, not a fallback); a
//!   drifting barometer leaves them apart, so the barometer is faulty.
//! * A faulty barometer: the height is reset to GPS and GPS height is fused instead, gated
//!   (EKF2 falls back to GNSS height on a baro fault), until the barometer has agreed with GPS
//!   again for [`RECOVERY_S`]. A refused GPS height is used again after the same. Without a
//!   usable GPS height a rejection run resets the height to the barometer instead (there is
//!   nothing else to believe).

use kestrel_proto::Time;
use kestrel_proto::messages::{AidingCounters, BaroSample, Innovation};

use crate::aiding::baro::{self, ClimbRate};
use crate::aiding::gps::GpsObservation;
use crate::aiding::{RejectionRun, Verdict, recent};
use crate::filter::Filter;
use crate::params::EkfParams;

/// Fixes whose baro-minus-GPS height difference is averaged before the check starts (10 s at
/// 5 Hz).
pub const AGREEMENT_FIXES: u32 = 50;
/// Time constant, in fixes, with which the agreed difference follows a slow GPS bias (100 s).
pub const AGREEMENT_TAU_FIXES: f64 = 500.0;
/// Time constant, in fixes, of the averages a disagreement is judged on (1 s).
pub const JUDGE_TAU_FIXES: f64 = 5.0;
/// How long a faulty barometer, or a refused GPS height, must agree with the other again to be
/// used again (s).
pub const RECOVERY_S: f64 = 10.0;

/// Which height source a disagreement between barometer and GPS height condemns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Culprit {
    Baro,
    GpsHeight,
}

/// Judges a disagreement: `baro_moved_m` and `gps_moved_m` are how far each height (down, m)
/// moved away from the velocity-propagated height since the two last agreed. The one that
/// moved further is faulty; a tie condemns GPS (the barometer is the height reference).
/// Held by `a_gps_height_step_is_refused_and_the_barometer_kept` and
/// `a_1_m_s_baro_drift_is_caught_against_the_velocity_height`.
pub fn culprit(baro_moved_m: f64, gps_moved_m: f64) -> Culprit {
    if baro_moved_m.abs() > gps_moved_m.abs() { Culprit::Baro } else { Culprit::GpsHeight }
}

/// The barometer checked against GPS height, with the velocity-propagated height as the judge.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct GpsAgreement {
    /// Mean of baro-down minus GPS-down (m), and the fixes in it.
    offset_m: f64,
    fixes: u32,
    disagreeing: RejectionRun,
    agreeing_since: Option<Time>,
    /// GPS's down velocity integrated over the fixes (m) and the last fix's time and down
    /// velocity (m/s): the velocity-propagated height, independent of either height sensor.
    velocity_down_m: f64,
    last: Option<(Time, f64)>,
    /// Baro-down and GPS-down minus the velocity height, each averaged over the last
    /// [`JUDGE_TAU_FIXES`] fixes (m): what a disagreement is judged on, GPS's 0.8 m of height
    /// noise averaged down.
    baro_rel_m: f64,
    gps_rel_m: f64,
    /// The same at the last fix where the two agreed well inside the tolerance (within half of
    /// it): a drift creeping past the tolerance, agreeing now and then on noise, does not move
    /// this point along with it.
    agreed_baro_m: f64,
    agreed_gps_m: f64,
}

/// Barometer fusion state.
#[derive(Clone, Debug, Default)]
pub struct BaroControl {
    /// Pressure altitude at zero height (m).
    offset_m: Option<f64>,
    last_fused: Option<Time>,
    /// The newest sample's height as down position (m) and its time.
    newest_down_m: Option<(Time, f64)>,
    gate_run: RejectionRun,
    agreement: GpsAgreement,
    /// The barometer is not trusted: height comes from GPS.
    faulty: bool,
    /// GPS height moved away from the barometer and the velocity height: it is not fused, nor a
    /// fallback.
    gps_height_faulty: bool,
    /// Found faulty: the next GPS fix resets the height.
    reset_to_gps: bool,
    pub counters: AidingCounters,
    pub height: Innovation,
    pub climb_rate: Innovation,
}

impl BaroControl {
    /// Sets the pressure altitude of zero height (m), from the alignment's mean.
    pub fn set_datum(&mut self, altitude_m: f64) {
        self.offset_m = Some(altitude_m);
    }

    /// The pressure altitude of zero height (m), once set.
    pub fn datum_m(&self) -> Option<f64> {
        self.offset_m
    }

    /// Whether height was fused within `baro_timeout_s` of `now`.
    pub fn height_aiding(&self, now: Time, params: &EkfParams) -> bool {
        recent(self.last_fused, now, params.baro_timeout_s)
    }

    /// Whether the barometer has been found faulty and GPS is the height source.
    pub fn faulty(&self) -> bool {
        self.faulty
    }

    /// Whether GPS height has been found to disagree with the barometer and the velocity height.
    pub fn gps_height_faulty(&self) -> bool {
        self.gps_height_faulty
    }

    /// Whether GPS height is fused: the barometer is faulty and GPS height is not.
    pub fn height_from_gps(&self) -> bool {
        self.faulty && !self.gps_height_faulty
    }

    /// Fuses the height of `sample` into `filter` (at the sample's time); `gps_available`: a
    /// usable GPS fix is recent, so a rejection run makes the barometer faulty rather than
    /// resetting the height to it (unless GPS height itself is refused).
    pub fn fuse_height(
        &mut self,
        filter: &mut Filter,
        sample: &BaroSample,
        params: &EkfParams,
        gps_available: bool,
    ) {
        let offset = *self.offset_m.get_or_insert(sample.altitude_m + filter.state.pos_ned_m.z);
        let down_m = offset - sample.altitude_m;
        let now = filter.state.time;
        self.newest_down_m = Some((now, down_m));
        self.height = baro::height_innovation(filter, down_m, params);
        if self.faulty && !self.gps_height_faulty {
            return;
        }
        match self.gate_run.judge(now, self.height.test_ratio <= 1.0, params.baro_timeout_s) {
            Verdict::Fuse => {
                if baro::fuse_height(filter, self.height.innovation, params) {
                    self.counters.fused += 1;
                    self.last_fused = Some(now);
                }
            }
            Verdict::Reject => self.counters.rejected += 1,
            Verdict::TimedOut if gps_available && !self.gps_height_faulty => {
                self.counters.rejected += 1;
                self.set_faulty(now, "barometric height rejected for too long");
            }
            Verdict::TimedOut => {
                tracing::warn!(time = %now, "barometric height rejected for too long, no usable GPS height: resetting to it");
                filter.reset_vertical_position(down_m, params.baro_height_noise_m.powi(2));
                self.counters.resets += 1;
                self.last_fused = Some(now);
            }
        }
    }

    /// Fuses a climb rate into `filter` (at the climb rate's time), unless the barometer is
    /// faulty.
    pub fn fuse_climb_rate(&mut self, filter: &mut Filter, climb: &ClimbRate, params: &EkfParams) {
        self.climb_rate = baro::climb_rate_innovation(filter, climb, params);
        if self.faulty {
            return;
        }
        if self.climb_rate.test_ratio > 1.0 {
            self.counters.rejected += 1;
            return;
        }
        baro::fuse_climb_rate(filter, self.climb_rate.innovation, params);
    }

    /// Checks the newest barometer height against the GPS fix `gps` (both at the filter's time
    /// `now`), the velocity-propagated height judging a disagreement ([`culprit`]): a faulty barometer
    /// resets the height to GPS and makes GPS the height source; a faulty GPS height is refused.
    /// Either, having agreed again for [`RECOVERY_S`], is used again.
    pub fn check_against_gps(&mut self, filter: &mut Filter, gps: &GpsObservation, params: &EkfParams) {
        let now = filter.state.time;
        let a = &mut self.agreement;
        let vz_m_s = gps.vel_ned_m_s.z;
        if let Some((t, last_vz)) = a.last {
            a.velocity_down_m += 0.5 * (last_vz + vz_m_s) * now.saturating_since(t).as_secs_f64();
        }
        a.last = Some((now, vz_m_s));
        if std::mem::take(&mut self.reset_to_gps) && !self.gps_height_faulty {
            filter.reset_vertical_position(gps.pos_ned_m.z, gps.height_var_m2);
            self.counters.resets += 1;
        }
        // Only a barometer sample close in time to the fix is compared (both lag-compensated).
        let Some((_, baro_down_m)) = self.newest_down_m.filter(|(t, _)| recent(Some(*t), now, 0.5)) else {
            return;
        };
        let difference_m = baro_down_m - gps.pos_ned_m.z;
        let a = &mut self.agreement;
        if a.fixes == 0 {
            (a.baro_rel_m, a.gps_rel_m) =
                (baro_down_m - a.velocity_down_m, gps.pos_ned_m.z - a.velocity_down_m);
        }
        a.baro_rel_m += (baro_down_m - a.velocity_down_m - a.baro_rel_m) / JUDGE_TAU_FIXES;
        a.gps_rel_m += (gps.pos_ned_m.z - a.velocity_down_m - a.gps_rel_m) / JUDGE_TAU_FIXES;
        let (baro_rel_m, gps_rel_m) = (a.baro_rel_m, a.gps_rel_m);
        if a.fixes < AGREEMENT_FIXES {
            a.fixes += 1;
            a.offset_m += (difference_m - a.offset_m) / f64::from(a.fixes);
            (a.agreed_baro_m, a.agreed_gps_m) = (baro_rel_m, gps_rel_m);
            return;
        }
        let agrees = (difference_m - a.offset_m).abs() <= params.baro_gps_tolerance_m;
        let healthy = !self.faulty && !self.gps_height_faulty;
        if agrees && healthy {
            a.offset_m += (difference_m - a.offset_m) / AGREEMENT_TAU_FIXES;
        }
        if healthy && (difference_m - a.offset_m).abs() <= 0.5 * params.baro_gps_tolerance_m {
            (a.agreed_baro_m, a.agreed_gps_m) = (baro_rel_m, gps_rel_m);
        }
        let verdict = a.disagreeing.judge(now, agrees, params.baro_fault_timeout_s);
        if !healthy {
            let since = if agrees { *a.agreeing_since.get_or_insert(now) } else { now };
            a.agreeing_since = agrees.then_some(since);
            if now.saturating_since(since).as_secs_f64() < RECOVERY_S {
                return;
            }
            a.agreeing_since = None;
            (a.agreed_baro_m, a.agreed_gps_m) = (baro_rel_m, gps_rel_m);
            if std::mem::take(&mut self.gps_height_faulty) {
                tracing::info!(time = %now, "GPS height agrees with the barometer again: usable again");
            }
            if self.faulty {
                tracing::info!(time = %now, "barometer agrees with GPS again: height from the barometer");
                self.faulty = false;
                self.gate_run.clear();
                filter.reset_vertical_position(baro_down_m - self.agreement.offset_m, gps.height_var_m2);
                self.counters.resets += 1;
            }
            return;
        }
        if verdict != Verdict::TimedOut {
            return;
        }
        let baro_moved_m = baro_rel_m - a.agreed_baro_m;
        let gps_moved_m = gps_rel_m - a.agreed_gps_m;
        match culprit(baro_moved_m, gps_moved_m) {
            Culprit::GpsHeight => {
                tracing::warn!(
                    time = %now, baro_moved_m, gps_moved_m,
                    "GPS height disagrees with the barometer and the velocity height: GPS height refused"
                );
                self.gps_height_faulty = true;
                a.agreeing_since = None;
            }
            Culprit::Baro => {
                self.set_faulty(now, "barometer moved away from the velocity height and GPS height");
                self.reset_to_gps = false;
                filter.reset_vertical_position(gps.pos_ned_m.z, gps.height_var_m2);
                self.counters.resets += 1;
            }
        }
    }

    fn set_faulty(&mut self, now: Time, why: &str) {
        tracing::warn!(time = %now, why, "barometer faulty: height from GPS");
        self.faulty = true;
        self.reset_to_gps = true;
        self.agreement.agreeing_since = None;
        self.gate_run.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::covariance::ProcessNoise;
    use crate::state::{ImuDelta, State};
    use kestrel_proto::units::GRAVITY_M_S2;
    use nalgebra::{UnitQuaternion, Vector3};

    const NOISE: ProcessNoise =
        ProcessNoise { gyro_rad_s: 0.015, accel_m_s2: 0.25, gyro_bias_rad_s2: 1e-3, accel_bias_m_s3: 3e-3 };

    /// A vehicle at rest at zero height for `seconds` from `start_s`: still IMU at 400 Hz, the
    /// barometer at 10 Hz reading `baro_alt(t)` (m above the datum of 100 m), and, when `gps_alt`
    /// gives one, a GPS fix at 5 Hz with that height (m) and zero velocity, fused as the GPS
    /// control fuses it (velocity always, height once the barometer is faulty).
    fn run(
        filter: &mut Filter,
        baro: &mut BaroControl,
        params: &EkfParams,
        (start_s, seconds): (f64, f64),
        baro_alt: impl Fn(f64) -> f64,
        gps_alt: impl Fn(f64) -> Option<f64>,
    ) {
        let steps = (seconds * 400.0).round() as u64;
        let first = (start_s * 400.0).round() as u64;
        for i in first + 1..=first + steps {
            let time = Time::from_micros(i * 2500);
            let t = time.as_secs_f64();
            filter.predict(&ImuDelta::from_rates(time, [0.0; 3], [0.0, 0.0, -GRAVITY_M_S2], 0.0025), &NOISE);
            if i.is_multiple_of(40) {
                let s = BaroSample {
                    time,
                    pressure_pa: 0.0,
                    altitude_m: 100.0 + baro_alt(t),
                    temperature_c: 20.0,
                };
                baro.fuse_height(filter, &s, params, gps_alt(t).is_some());
            }
            if i.is_multiple_of(80)
                && let Some(alt_m) = gps_alt(t)
            {
                let obs = GpsObservation {
                    pos_ned_m: Vector3::new(0.0, 0.0, -alt_m),
                    vel_ned_m_s: Vector3::zeros(),
                    pos_var_m2: 0.25,
                    height_var_m2: 1.0,
                    vel_var_m2_s2: 0.01,
                };
                crate::aiding::gps::fuse_velocity(filter, &obs);
                if baro.height_from_gps() {
                    crate::aiding::gps::fuse_height(filter, &obs);
                }
                baro.check_against_gps(filter, &obs, params);
            }
        }
    }

    fn bench() -> (Filter, BaroControl, EkfParams) {
        let filter = Filter::aligned(State::at_rest(Time::ZERO, UnitQuaternion::identity()), true);
        let mut baro = BaroControl::default();
        baro.set_datum(100.0);
        (filter, baro, EkfParams::default())
    }

    fn height_m(f: &Filter) -> f64 {
        -f.state.pos_ned_m.z
    }

    #[test]
    fn the_source_that_left_the_velocity_height_is_the_culprit() {
        assert_eq!(culprit(0.3, -10.0), Culprit::GpsHeight);
        assert_eq!(culprit(5.0, 0.5), Culprit::Baro);
        assert_eq!(culprit(-5.0, 0.5), Culprit::Baro);
        assert_eq!(culprit(2.0, 2.0), Culprit::GpsHeight, "a tie keeps the height reference");
    }

    #[test]
    fn a_1_m_s_baro_drift_is_caught_against_the_velocity_height_and_height_comes_from_gps_until_it_agrees_again()
     {
        let (mut f, mut baro, p) = bench();
        let gps = |_| Some(0.0);
        run(&mut f, &mut baro, &p, (0.0, 20.0), |_| 0.0, gps);
        assert!(!baro.faulty());
        let drift = |t: f64| if (20.0..40.0).contains(&t) { t - 20.0 } else { 0.0 };
        let mut caught_at = None;
        for k in 0..200 {
            let t0 = 20.0 + 0.1 * f64::from(k);
            run(&mut f, &mut baro, &p, (t0, 0.1), drift, gps);
            if baro.faulty() && caught_at.is_none() {
                caught_at = Some(t0 + 0.1 - 20.0);
            }
            // The estimate follows the drift at most until it is caught, then stays near GPS.
            assert!(height_m(&f) < p.baro_gps_tolerance_m + 2.0, "height {} at {t0}", height_m(&f));
        }
        assert!(!baro.gps_height_faulty(), "GPS height, with the velocity height, is not the culprit");
        let caught_s = caught_at.expect("the drift was caught");
        // tolerance / rate + the fault timeout, and some lag of the filter behind the drift.
        assert!(caught_s > 4.0 && caught_s < 7.0, "caught after {caught_s} s");
        assert!(f.state.pos_ned_m.z.abs() < 1.5, "height from GPS: {}", height_m(&f));
        // The drift is gone at 40 s: after RECOVERY_S of agreement the barometer is used again.
        run(&mut f, &mut baro, &p, (40.0, RECOVERY_S - 1.0), drift, gps);
        assert!(baro.faulty());
        run(&mut f, &mut baro, &p, (39.0 + RECOVERY_S, 2.0), drift, gps);
        assert!(!baro.faulty());
        assert!(f.state.pos_ned_m.z.abs() < 1.0);
    }

    #[test]
    fn a_gps_height_step_is_refused_and_the_barometer_kept() {
        let (mut f, mut baro, p) = bench();
        run(&mut f, &mut baro, &p, (0.0, 20.0), |_| 0.0, |_| Some(0.0));
        // GPS reports 10 m higher from 20 s to 80 s; the barometer and the IMU say still.
        let step = |t: f64| Some(if (20.0..80.0).contains(&t) { 10.0 } else { 0.0 });
        let mut refused_at = None;
        for k in 0..600 {
            let t0 = 20.0 + 0.1 * f64::from(k);
            run(&mut f, &mut baro, &p, (t0, 0.1), |_| 0.0, step);
            if baro.gps_height_faulty() && refused_at.is_none() {
                refused_at = Some(t0 + 0.1 - 20.0);
            }
            assert!(!baro.faulty(), "barometer found faulty at {t0} s");
            assert!(height_m(&f).abs() < 1.0, "height {} at {t0} s", height_m(&f));
        }
        let refused_s = refused_at.expect("GPS height refused");
        // The first disagreeing fix plus the fault timeout (1 s), to a fix (0.2 s).
        assert!(refused_s <= p.baro_fault_timeout_s + 0.5, "refused after {refused_s} s");
        assert!(baro.gps_height_faulty() && !baro.height_from_gps());
        assert!(baro.height_aiding(f.state.time, &p), "the barometer still fused");
        // The step ends at 80 s: GPS height is usable again after RECOVERY_S of agreement.
        run(&mut f, &mut baro, &p, (80.0, RECOVERY_S + 1.0), |_| 0.0, step);
        assert!(!baro.gps_height_faulty());
    }

    #[test]
    fn a_30_m_baro_step_with_gps_makes_the_barometer_faulty_and_height_comes_from_gps() {
        let (mut f, mut baro, p) = bench();
        run(&mut f, &mut baro, &p, (0.0, 20.0), |_| 0.0, |_| Some(0.0));
        run(&mut f, &mut baro, &p, (20.0, 3.0), |_| 30.0, |_| Some(0.0));
        assert!(baro.faulty() && !baro.gps_height_faulty());
        assert!(height_m(&f).abs() < 1.0, "height {}", height_m(&f));
    }

    #[test]
    fn without_gps_a_rejection_run_resets_the_height_to_the_barometer() {
        let (mut f, mut baro, p) = bench();
        run(&mut f, &mut baro, &p, (0.0, 10.0), |_| 0.0, |_| None);
        let resets = baro.counters.resets;
        // A 30 m step (far outside the gate) held: rejected, then taken after baro_timeout_s.
        run(&mut f, &mut baro, &p, (10.0, p.baro_timeout_s - 0.5), |_| 30.0, |_| None);
        assert!(f.state.pos_ned_m.z.abs() < 1.0, "rejected at first");
        run(&mut f, &mut baro, &p, (9.5 + p.baro_timeout_s, 1.0), |_| 30.0, |_| None);
        assert!((f.state.pos_ned_m.z + 30.0).abs() < 1.0, "reset to the barometer: {}", f.state.pos_ned_m.z);
        assert_eq!(baro.counters.resets, resets + 1);
        assert!(!baro.faulty(), "without GPS the barometer is all there is");
    }
}
