//! Barometer, when to fuse, and the height source (PX4 EKF2's `baro_height_control.cpp` and its
//! height source switching).
//!
//! * The alignment's mean pressure altitude fixes the offset between pressure altitude and the
//!   filter's height (the barometer observes height changes, not altitude above sea level);
//!   without a barometer during alignment the first sample after it does. Height and climb rate
//!   are gated at `baro_gate_sigma`.
//! * A slow drift never leaves the gate: the filter follows it. So each GPS fix checks the
//!   barometer against GPS height, an independent reference: their difference, once its mean is
//!   learnt (the first [`AGREEMENT_FIXES`] fixes, then tracked with a [`AGREEMENT_TAU_FIXES`]-fix
//!   time constant while they agree), may not move by more than `baro_gps_tolerance_m` for longer
//!   than `baro_fault_timeout_s`; nor may the height innovation stay outside its gate that long.
//!   Either makes the barometer faulty: the height is reset to GPS and GPS height is fused
//!   instead (EKF2 falls back to GNSS height on a baro fault), until the barometer has agreed
//!   with GPS again for [`RECOVERY_S`]. Without GPS a rejection run resets the height to the
//!   barometer instead (there is nothing else to believe).

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
/// How long a faulty barometer must agree with GPS again to be used again (s).
pub const RECOVERY_S: f64 = 10.0;

/// The barometer checked against GPS height.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct GpsAgreement {
    /// Mean of baro-down minus GPS-down (m), and the fixes in it.
    offset_m: f64,
    fixes: u32,
    disagreeing: RejectionRun,
    agreeing_since: Option<Time>,
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

    /// Fuses the height of `sample` into `filter` (at the sample's time); `gps_available`: a
    /// usable GPS fix is recent, so a rejection run makes the barometer faulty rather than
    /// resetting the height to it.
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
        if self.faulty {
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
            Verdict::TimedOut if gps_available => {
                self.counters.rejected += 1;
                self.set_faulty(now, "barometric height rejected for too long");
            }
            Verdict::TimedOut => {
                tracing::warn!(time = %now, "barometric height rejected for too long, no GPS: resetting to it");
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
    /// `now`): on a fault, resets the height to GPS and makes GPS the height source; a faulty
    /// barometer that has agreed again for [`RECOVERY_S`] is used again.
    pub fn check_against_gps(&mut self, filter: &mut Filter, gps: &GpsObservation, params: &EkfParams) {
        let now = filter.state.time;
        if std::mem::take(&mut self.reset_to_gps) {
            filter.reset_vertical_position(gps.pos_ned_m.z, gps.height_var_m2);
            self.counters.resets += 1;
        }
        // Only a barometer sample close in time to the fix is compared (both lag-compensated).
        let Some((_, baro_down_m)) = self.newest_down_m.filter(|(t, _)| recent(Some(*t), now, 0.5)) else {
            return;
        };
        let difference_m = baro_down_m - gps.pos_ned_m.z;
        let a = &mut self.agreement;
        if a.fixes < AGREEMENT_FIXES {
            a.fixes += 1;
            a.offset_m += (difference_m - a.offset_m) / f64::from(a.fixes);
            return;
        }
        let agrees = (difference_m - a.offset_m).abs() <= params.baro_gps_tolerance_m;
        if agrees && !self.faulty {
            a.offset_m += (difference_m - a.offset_m) / AGREEMENT_TAU_FIXES;
        }
        let verdict = a.disagreeing.judge(now, agrees, params.baro_fault_timeout_s);
        if self.faulty {
            let since = if agrees { *a.agreeing_since.get_or_insert(now) } else { now };
            a.agreeing_since = agrees.then_some(since);
            if now.saturating_since(since).as_secs_f64() >= RECOVERY_S {
                tracing::info!(time = %now, "barometer agrees with GPS again: height from the barometer");
                self.faulty = false;
                a.agreeing_since = None;
                self.gate_run.clear();
                filter.reset_vertical_position(baro_down_m - a.offset_m, gps.height_var_m2);
                self.counters.resets += 1;
            }
            return;
        }
        if verdict == Verdict::TimedOut {
            self.set_faulty(now, "barometer disagrees with GPS height");
            self.reset_to_gps = false;
            filter.reset_vertical_position(gps.pos_ned_m.z, gps.height_var_m2);
            self.counters.resets += 1;
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
    /// barometer at 10 Hz reading `baro_alt(t)` (m above the datum of 100 m), and GPS height 0
    /// at 5 Hz when `gps`.
    fn run(
        filter: &mut Filter,
        baro: &mut BaroControl,
        params: &EkfParams,
        (start_s, seconds): (f64, f64),
        baro_alt: impl Fn(f64) -> f64,
        gps: bool,
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
                baro.fuse_height(filter, &s, params, gps);
            }
            if gps && i.is_multiple_of(80) {
                let obs = GpsObservation {
                    pos_ned_m: Vector3::zeros(),
                    vel_ned_m_s: Vector3::zeros(),
                    pos_var_m2: 0.25,
                    height_var_m2: 1.0,
                    vel_var_m2_s2: 0.01,
                };
                // Height from GPS, as the GPS control fuses it once the barometer is faulty.
                if baro.faulty() {
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

    #[test]
    fn a_1_m_s_drift_is_caught_against_gps_and_height_comes_from_gps_until_the_baro_agrees_again() {
        let (mut f, mut baro, p) = bench();
        run(&mut f, &mut baro, &p, (0.0, 20.0), |_| 0.0, true);
        assert!(!baro.faulty());
        let drift = |t: f64| if (20.0..40.0).contains(&t) { t - 20.0 } else { 0.0 };
        let mut caught_at = None;
        for k in 0..200 {
            let t0 = 20.0 + 0.1 * f64::from(k);
            run(&mut f, &mut baro, &p, (t0, 0.1), drift, true);
            if baro.faulty() && caught_at.is_none() {
                caught_at = Some(t0 + 0.1 - 20.0);
            }
            // The estimate follows the drift at most until it is caught, then stays near GPS.
            assert!(
                -f.state.pos_ned_m.z < p.baro_gps_tolerance_m + 2.0,
                "height {} at {t0}",
                -f.state.pos_ned_m.z
            );
        }
        let caught_s = caught_at.expect("the drift was caught");
        // tolerance / rate + the fault timeout, and some lag of the filter behind the drift.
        assert!(caught_s > 4.0 && caught_s < 7.0, "caught after {caught_s} s");
        assert!(f.state.pos_ned_m.z.abs() < 1.5, "height from GPS: {}", -f.state.pos_ned_m.z);
        // The drift is gone at 40 s: after RECOVERY_S of agreement the barometer is used again.
        run(&mut f, &mut baro, &p, (40.0, RECOVERY_S - 1.0), drift, true);
        assert!(baro.faulty());
        run(&mut f, &mut baro, &p, (39.0 + RECOVERY_S, 2.0), drift, true);
        assert!(!baro.faulty());
        assert!(f.state.pos_ned_m.z.abs() < 1.0);
    }

    #[test]
    fn without_gps_a_rejection_run_resets_the_height_to_the_barometer() {
        let (mut f, mut baro, p) = bench();
        run(&mut f, &mut baro, &p, (0.0, 10.0), |_| 0.0, false);
        let resets = baro.counters.resets;
        // A 30 m step (far outside the gate) held: rejected, then taken after baro_timeout_s.
        run(&mut f, &mut baro, &p, (10.0, p.baro_timeout_s - 0.5), |_| 30.0, false);
        assert!(f.state.pos_ned_m.z.abs() < 1.0, "rejected at first");
        run(&mut f, &mut baro, &p, (9.5 + p.baro_timeout_s, 1.0), |_| 30.0, false);
        assert!((f.state.pos_ned_m.z + 30.0).abs() < 1.0, "reset to the barometer: {}", f.state.pos_ned_m.z);
        assert_eq!(baro.counters.resets, resets + 1);
        assert!(!baro.faulty(), "without GPS the barometer is all there is");
    }
}
