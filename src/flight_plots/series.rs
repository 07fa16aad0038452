//! The time series a report plots, read from a flight log and put in one frame: the estimator's
//! local NED frame (the first `NavState::origin`), with times in seconds from the log's first
//! message.
//!
//! Sensor samples keep two times: when they were *measured* and when they *arrived*. Plots draw
//! sensors at arrival, as the thesis logged them (so the lag shows, Fig. 4.7); errors compare
//! the estimate with each sample at its measurement time.

use kestrel_estimator::aiding::baro::ClimbRateFit;
use kestrel_proto::attitude::euler_rad;
use kestrel_proto::geo::{Geodetic, LocalFrame};
use kestrel_proto::messages::{BaroSample, GpsFix, GpsFixType, GroundTruth, NavState};
use kestrel_proto::{Message, Time};

use super::PlotError;
use crate::recorder::{LogReader, Recorded};

/// Largest gap between a sample and the estimate it is compared with (s): the estimate comes at
/// IMU rate (400 Hz), so in a healthy log the nearest one is at most 1.25 ms away.
const PAIR_TOLERANCE_S: f64 = 0.01;

/// A sensor value with the two times that matter for a lagged sensor.
#[derive(Clone, Debug)]
pub(crate) struct Timed<T> {
    /// When the quantity was measured (s from the log's start).
    pub measured_s: f64,
    /// When it reached the software and was logged (s from the log's start).
    pub arrived_s: f64,
    pub value: T,
}

/// A GPS fix in the report frame.
#[derive(Clone, Debug)]
pub(crate) struct GpsPoint {
    /// North, east, down of the fix from the report origin (m).
    pub position_ned_m: [f64; 3],
    /// Velocity north, east, down (m/s).
    pub velocity_ned_m_s: [f64; 3],
}

/// One estimate, or one ground-truth sample, in the report frame.
#[derive(Clone, Debug)]
pub(crate) struct StatePoint {
    /// Time the state is valid at (s from the log's start).
    pub t_s: f64,
    /// North, east, down from the report origin (m).
    pub position_ned_m: [f64; 3],
    /// Velocity north, east, down (m/s).
    pub velocity_ned_m_s: [f64; 3],
    /// Roll, pitch, yaw (rad, Z-Y-X); `None` while the estimator's attitude is not valid.
    pub euler_rad: Option<[f64; 3]>,
}

/// Everything a report draws, in the estimator's frame.
pub(crate) struct FlightSeries {
    /// The report frame's origin: the estimator's first `NavState::origin`.
    pub origin: Geodetic,
    /// From the log's first message to its last (s).
    pub duration_s: f64,
    /// The estimate at IMU rate, from the first sample with an origin, in time order.
    pub nav: Vec<StatePoint>,
    /// 3-D GPS fixes.
    pub gps: Vec<Timed<GpsPoint>>,
    /// Barometric height above the origin (m, up), less [`FlightSeries::baro_offset_m`].
    pub baro_height_m: Vec<Timed<f64>>,
    /// Mean of barometric height above the origin minus the estimated height (m): pressure
    /// altitude sits an unknown constant away from GPS altitude, and the estimator, like this
    /// report, only trusts the barometer's changes in height.
    pub baro_offset_m: f64,
    /// Climb rate (m/s, up) from the barometer: the slope of its last five heights, as the
    /// estimator fits it, measured at the window's mean time.
    pub baro_climb_m_s: Vec<Timed<f64>>,
    /// Simulator ground truth, when the log has it.
    pub truth: Option<Vec<StatePoint>>,
    /// Turns a log time into the seconds every plot's time axis uses, for figures that read
    /// further topics.
    pub clock: LogClock,
}

impl FlightSeries {
    /// Reads the estimate, GPS, barometer and (if present) ground truth from `log`.
    pub fn read(log: &LogReader) -> Result<FlightSeries, PlotError> {
        let nav: Vec<Recorded<NavState>> = require(log, "nav_state", "the estimate")?;
        let gps: Vec<Recorded<GpsFix>> = require(log, "gps", "the GPS plots")?;
        let baro: Vec<Recorded<BaroSample>> = require(log, "baro", "the barometer plots")?;
        let truth: Option<Vec<Recorded<GroundTruth>>> = match topic_of::<GroundTruth>(log, "ground_truth") {
            Some(topic) => Some(log.read(&topic)?),
            None => None,
        };

        let origin = nav
            .iter()
            .find_map(|n| n.message.origin)
            .ok_or_else(|| PlotError::NoOrigin { path: log.path().to_owned() })?;
        let frame = LocalFrame::new(origin);
        let clock = LogClock::new(
            times(&nav).chain(times(&gps)).chain(times(&baro)).chain(truth.iter().flat_map(|t| times(t))),
        );

        let mut nav_points: Vec<StatePoint> =
            nav.iter().filter_map(|n| nav_point(&frame, &n.message, clock.secs(n.publish_time))).collect();
        nav_points.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));

        let gps_points = gps
            .iter()
            .filter(|g| g.message.fix_type >= GpsFixType::Fix3d)
            .map(|g| {
                let fix = &g.message;
                let here = Geodetic { lat_deg: fix.lat_deg, lon_deg: fix.lon_deg, alt_m: fix.alt_msl_m };
                Timed {
                    measured_s: clock.secs(g.publish_time),
                    arrived_s: clock.secs(g.log_time),
                    value: GpsPoint { position_ned_m: frame.to_ned(here), velocity_ned_m_s: fix.vel_ned_m_s },
                }
            })
            .collect();

        let truth_points = truth.map(|truth| {
            truth
                .iter()
                .map(|t| {
                    let g = &t.message;
                    let here = Geodetic { lat_deg: g.lat_deg, lon_deg: g.lon_deg, alt_m: g.alt_msl_m };
                    StatePoint {
                        t_s: clock.secs(t.publish_time),
                        position_ned_m: frame.to_ned(here),
                        velocity_ned_m_s: g.velocity_ned_m_s,
                        euler_rad: Some(euler_rad(g.attitude)),
                    }
                })
                .collect()
        });

        let mut series = FlightSeries {
            origin,
            duration_s: clock.secs(clock.last),
            nav: nav_points,
            gps: gps_points,
            baro_height_m: Vec::new(),
            baro_offset_m: 0.0,
            baro_climb_m_s: Vec::new(),
            truth: truth_points,
            clock,
        };
        series.add_baro(&baro, &clock);
        Ok(series)
    }

    /// The estimate nearest to `t_s`, if one is within [`PAIR_TOLERANCE_S`].
    pub fn nav_at(&self, t_s: f64) -> Option<&StatePoint> {
        let i = self.nav.partition_point(|n| n.t_s < t_s);
        let before = i.checked_sub(1).and_then(|j| self.nav.get(j));
        let nearest = match (before, self.nav.get(i)) {
            (Some(a), Some(b)) => Some(if t_s - a.t_s <= b.t_s - t_s { a } else { b }),
            (a, b) => a.or(b),
        };
        nearest.filter(|n| (n.t_s - t_s).abs() <= PAIR_TOLERANCE_S)
    }

    /// Each GPS fix with the estimate at its time of validity.
    pub fn gps_pairs(&self) -> impl Iterator<Item = (&Timed<GpsPoint>, &StatePoint)> {
        self.gps.iter().filter_map(|g| Some((g, self.nav_at(g.measured_s)?)))
    }

    /// Each ground-truth sample with the estimate of the same instant.
    pub fn truth_pairs(&self) -> impl Iterator<Item = (&StatePoint, &StatePoint)> {
        self.truth.iter().flatten().filter_map(|t| Some((t, self.nav_at(t.t_s)?)))
    }

    /// Each barometric value with the estimate at its measurement time.
    pub fn baro_pairs<'a>(
        &'a self,
        samples: &'a [Timed<f64>],
    ) -> impl Iterator<Item = (&'a Timed<f64>, &'a StatePoint)> + 'a {
        samples.iter().filter_map(|s| Some((s, self.nav_at(s.measured_s)?)))
    }

    /// Converts barometer samples into heights above the origin, offset to the estimate's mean,
    /// and climb rates.
    fn add_baro(&mut self, baro: &[Recorded<BaroSample>], clock: &LogClock) {
        let raw: Vec<Timed<f64>> = baro
            .iter()
            .map(|b| Timed {
                measured_s: clock.secs(b.publish_time),
                arrived_s: clock.secs(b.log_time),
                value: b.message.altitude_m - self.origin.alt_m,
            })
            .collect();
        let offsets: Vec<f64> = self.baro_pairs(&raw).map(|(b, n)| b.value + n.position_ned_m[2]).collect();
        self.baro_offset_m =
            if offsets.is_empty() { 0.0 } else { offsets.iter().sum::<f64>() / offsets.len() as f64 };
        self.baro_height_m =
            raw.into_iter().map(|b| Timed { value: b.value - self.baro_offset_m, ..b }).collect();

        let mut fit = ClimbRateFit::default();
        self.baro_climb_m_s = baro
            .iter()
            .filter_map(|b| {
                let rate = fit.push(&b.message)?;
                Some(Timed {
                    measured_s: clock.secs(rate.time),
                    arrived_s: clock.secs(b.log_time),
                    value: rate.climb_m_s,
                })
            })
            .collect();
    }
}

/// A NavState in the report frame, or `None` before the estimator has an origin.
fn nav_point(frame: &LocalFrame, nav: &NavState, t_s: f64) -> Option<StatePoint> {
    let origin = nav.origin?;
    let position_ned_m = if origin == frame.home() {
        nav.position_ned_m
    } else {
        frame.to_ned(LocalFrame::new(origin).to_geodetic(nav.position_ned_m))
    };
    Some(StatePoint {
        t_s,
        position_ned_m,
        velocity_ned_m_s: nav.velocity_ned_m_s,
        euler_rad: nav.valid.attitude.then(|| euler_rad(nav.attitude)),
    })
}

/// Seconds from the log's first message.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LogClock {
    first: Time,
    last: Time,
}

impl LogClock {
    fn new(times: impl Iterator<Item = Time>) -> LogClock {
        let (first, last) = times.fold((Time(u64::MAX), Time::ZERO), |(lo, hi), t| (lo.min(t), hi.max(t)));
        LogClock { first: first.min(last), last }
    }

    /// `t` in seconds from the first message.
    pub fn secs(&self, t: Time) -> f64 {
        t.saturating_since(self.first).as_secs_f64()
    }
}

/// Both times of each record.
fn times<T>(records: &[Recorded<T>]) -> impl Iterator<Item = Time> + '_ {
    records.iter().flat_map(|r| [r.log_time, r.publish_time])
}

/// The topic carrying `T`: `preferred` if it does, else the first that does.
pub(crate) fn topic_of<T: Message>(log: &LogReader, preferred: &str) -> Option<String> {
    let topics: Vec<String> =
        log.topics().into_iter().filter(|t| t.schema_name == T::TYPE_NAME).map(|t| t.topic).collect();
    topics.iter().find(|t| *t == preferred).or(topics.first()).cloned()
}

/// Every `T` in the log, or an error saying what the report needed it for.
fn require<T: Message>(
    log: &LogReader,
    preferred: &str,
    needed_for: &'static str,
) -> Result<Vec<Recorded<T>>, PlotError> {
    let topic = topic_of::<T>(log, preferred).ok_or_else(|| PlotError::MissingTopic {
        path: log.path().to_owned(),
        type_name: T::TYPE_NAME,
        needed_for,
        available: log.topics().into_iter().map(|t| format!("{} ({})", t.topic, t.schema_name)).collect(),
    })?;
    Ok(log.read(&topic)?)
}
