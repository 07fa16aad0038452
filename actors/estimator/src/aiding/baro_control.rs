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
    pub fn fuse_height(&mut self, filter: &mut Filter, sample: &BaroSample, params: &EkfParams, gps_available: bool) {
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
