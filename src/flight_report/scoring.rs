//! How the report's figures are computed, each from the messages it needs and nothing else:
//! estimate errors against the truth of the same instant ([`ErrorSums`], [`truth_at`]), the
//! cross-track error along the legs flown ([`Tracking`]), the true path while airborne
//! ([`AirbornePath`]) and the time the forward speed cap held the vehicle back
//! ([`SpeedCapTally`]). Pure and synchronous: [`super::actor`] feeds them.

use std::collections::{BTreeMap, VecDeque};

use kestrel_proto::Time;
use kestrel_proto::attitude::{angle_difference_rad, euler_rad, tilt_rad, unit_quaternion};
use kestrel_proto::messages::{GroundTruth, NavState, SpeedCapStatus};

use super::schema::{EstimatorSection, Touchdown};
use crate::serde_name::serde_name;

/// Sums of squared estimate errors against the truth (m², (m/s)², rad²), and the worst
/// horizontal error.
#[derive(Debug, Default)]
pub(super) struct ErrorSums {
    horizontal: f64,
    /// Largest horizontal error (m), not squared.
    horizontal_max: f64,
    vertical: f64,
    velocity: f64,
    roll_pitch: f64,
    yaw: f64,
    samples: u64,
}

impl ErrorSums {
    /// Adds `nav`'s errors against `truth` of the same instant, whose position in `nav`'s
    /// frame is `true_ned` (m). Roll and pitch count as their mean square.
    pub(super) fn add(&mut self, nav: &NavState, truth: &GroundTruth, true_ned: [f64; 3]) {
        let d = |i: usize| nav.position_ned_m[i] - true_ned[i];
        let dv = |i: usize| nav.velocity_ned_m_s[i] - truth.velocity_ned_m_s[i];
        let (est, tru) = (euler_rad(nav.attitude), euler_rad(truth.attitude));
        self.horizontal += d(0).powi(2) + d(1).powi(2);
        self.horizontal_max = self.horizontal_max.max(d(0).hypot(d(1)));
        self.vertical += d(2).powi(2);
        self.velocity += dv(0).powi(2) + dv(1).powi(2) + dv(2).powi(2);
        self.roll_pitch += (angle_difference_rad(est[0], tru[0]).powi(2)
            + angle_difference_rad(est[1], tru[1]).powi(2))
            / 2.0;
        self.yaw += angle_difference_rad(est[2], tru[2]).powi(2);
        self.samples += 1;
    }

    /// The root-mean-square errors; `None` before the first sample.
    pub(super) fn section(&self) -> Option<EstimatorSection> {
        let rms = |sum: f64| (sum / self.samples as f64).sqrt();
        (self.samples > 0).then(|| EstimatorSection {
            rms_horizontal_m: rms(self.horizontal),
            rms_vertical_m: rms(self.vertical),
            rms_velocity_m_s: rms(self.velocity),
            rms_roll_pitch_deg: rms(self.roll_pitch).to_degrees(),
            rms_yaw_deg: rms(self.yaw).to_degrees(),
            max_horizontal_m: self.horizontal_max,
            samples: self.samples,
        })
    }
}

/// Cross-track error along the legs the commander flies: from one position target to the next.
#[derive(Debug, Default)]
pub(super) struct Tracking {
    /// The previous and the current position target (m, NED in the estimator's frame).
    leg: (Option<[f64; 3]>, Option<[f64; 3]>),
    max_m: f64,
    sum_sq: f64,
    samples: u64,
}

impl Tracking {
    /// A new setpoint: a full position target extends the path; anything else (a velocity-
    /// controlled axis while landing, attitude or rate control) is not a path to track.
    pub(super) fn on_setpoint(&mut self, target: Option<[f64; 3]>) {
        match target {
            Some(t) if self.leg.1 != Some(t) => self.leg = (self.leg.1, Some(t)),
            Some(_) => {}
            None => self.leg = (None, None),
        }
    }

    /// Adds the distance of `p` from the current leg.
    pub(super) fn on_position(&mut self, p: [f64; 3]) {
        let (Some(a), Some(b)) = self.leg else { return };
        let ab = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let ap = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
        let length_sq: f64 = ab.iter().map(|x| x * x).sum();
        let along = if length_sq > 0.0 {
            (ab.iter().zip(&ap).map(|(x, y)| x * y).sum::<f64>() / length_sq).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let distance = (0..3).map(|i| (ap[i] - along * ab[i]).powi(2)).sum::<f64>().sqrt();
        self.max_m = self.max_m.max(distance);
        self.sum_sq += distance * distance;
        self.samples += 1;
    }

    /// Largest distance from the leg (m); `None` when no leg was flown.
    pub(super) fn max_m(&self) -> Option<f64> {
        (self.samples > 0).then_some(self.max_m)
    }

    /// RMS of the distance from the leg (m); `None` when no leg was flown.
    pub(super) fn rms_m(&self) -> Option<f64> {
        (self.samples > 0).then(|| (self.sum_sq / self.samples as f64).sqrt())
    }
}

/// The truth at `time`: the sample stamped then (lockstep: the simulator and the estimator
/// share the IMU's instants), else, as on the wall clock where a driver stamps its own reads,
/// position and velocity interpolated between the samples either side and the nearer one's
/// attitude. `None` outside the window.
pub(super) fn truth_at(window: &VecDeque<GroundTruth>, time: Time) -> Option<GroundTruth> {
    if let Some(exact) = window.iter().find(|t| t.time == time) {
        return Some(exact.clone());
    }
    let after = window.iter().position(|t| t.time > time)?;
    let (a, b) = (window.get(after.checked_sub(1)?)?, &window[after]);
    if a.time > time {
        return None;
    }
    let span = (b.time.as_micros() - a.time.as_micros()) as f64;
    let w = (time.as_micros() - a.time.as_micros()) as f64 / span;
    let mix = |x: f64, y: f64| x + (y - x) * w;
    let mut t = if w < 0.5 { a.clone() } else { b.clone() };
    t.time = time;
    t.lat_deg = mix(a.lat_deg, b.lat_deg);
    t.lon_deg = mix(a.lon_deg, b.lon_deg);
    t.alt_msl_m = mix(a.alt_msl_m, b.alt_msl_m);
    t.velocity_ned_m_s = std::array::from_fn(|i| mix(a.velocity_ned_m_s[i], b.velocity_ned_m_s[i]));
    t.position_ned_m = std::array::from_fn(|i| mix(a.position_ned_m[i], b.position_ned_m[i]));
    Some(t)
}

/// Angle of the body's down axis from NED down (degrees) for the attitude `[w, x, y, z]`; NaN
/// for one that is no rotation (the simulator's truth always is; `f64::max` passes NaN over).
pub(super) fn tilt_deg(q: [f64; 4]) -> f64 {
    unit_quaternion(q).map_or(f64::NAN, |q| tilt_rad(&q).to_degrees())
}

/// The true path while airborne, from the ground truth: its horizontal length, its ends, the
/// worst tilt, and how the last touchdown met the ground.
#[derive(Debug, Default)]
pub(super) struct AirbornePath {
    /// Horizontal length (m) and the first and latest airborne points (NED, m).
    pub(super) length_m: f64,
    first: Option<[f64; 2]>,
    last: Option<[f64; 2]>,
    /// Largest tilt while airborne (degrees).
    pub(super) max_tilt_deg: f64,
    /// The latest airborne sample's downward speed and tilt, and the last touchdown.
    airborne_touchdown: Option<Touchdown>,
    pub(super) touchdown: Option<Touchdown>,
}

impl AirbornePath {
    pub(super) fn on_truth(&mut self, truth: &GroundTruth) {
        if truth.landed {
            self.touchdown = self.airborne_touchdown.take().or(self.touchdown);
            return;
        }
        let tilt = tilt_deg(truth.attitude);
        self.max_tilt_deg = self.max_tilt_deg.max(tilt);
        self.airborne_touchdown =
            Some(Touchdown { speed_down_m_s: truth.velocity_ned_m_s[2], tilt_deg: tilt });
        let here = [truth.position_ned_m[0], truth.position_ned_m[1]];
        if let Some(last) = self.last {
            self.length_m += (here[0] - last[0]).hypot(here[1] - last[1]);
        }
        self.first.get_or_insert(here);
        self.last = Some(here);
    }

    /// Horizontal straight-line distance from take-off to the latest airborne point (m); 0
    /// before take-off.
    pub(super) fn straight_line_m(&self) -> f64 {
        match (self.first, self.last) {
            (Some(a), Some(b)) => (b[0] - a[0]).hypot(b[1] - a[1]),
            _ => 0.0,
        }
    }
}

/// The speed cap's account from the commander's statuses: a status whose cap limits counts
/// until the next status (s of graph time, per [`ClearRangeReason`] name).
///
/// [`ClearRangeReason`]: kestrel_proto::messages::ClearRangeReason
#[derive(Debug, Default)]
pub(super) struct SpeedCapTally {
    /// The previous status's time and cap.
    previous: Option<(Time, Option<SpeedCapStatus>)>,
    pub(super) by_reason: BTreeMap<String, f64>,
    pub(super) lowest_m_s: Option<f64>,
}

impl SpeedCapTally {
    /// A status at `time` with `cap`.
    pub(super) fn on_status(&mut self, time: Time, cap: Option<SpeedCapStatus>) {
        if let Some((since, Some(limiting))) = self.previous.map(|(t, c)| (t, c.filter(|c| c.limiting))) {
            let dt_s = time.saturating_since(since).as_secs_f64();
            *self.by_reason.entry(serde_name(&limiting.reason)).or_default() += dt_s;
        }
        if let Some(cap) = cap.filter(|c| c.limiting) {
            self.lowest_m_s = Some(self.lowest_m_s.map_or(cap.cap_m_s, |l| l.min(cap.cap_m_s)));
        }
        self.previous = Some((time, cap));
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::messages::ClearRangeReason;

    use super::*;

    #[test]
    fn tilt_is_the_angle_of_body_down_from_ned_down() {
        let (roll, pitch, yaw) = (0.3f64, -0.5f64, 2.0f64);
        let ((sx, cx), (sy, cy), (sz, cz)) =
            ((roll / 2.0).sin_cos(), (pitch / 2.0).sin_cos(), (yaw / 2.0).sin_cos());
        // Yaw then roll (q_z · q_x): the tilt is the roll; pitch then roll (q_y · q_x): body down
        // is (.., .., cos θ · cos φ) in NED.
        let yawed_roll = [cz * cx, cz * sx, sz * sx, sz * cx];
        let pitched_roll = [cy * cx, cy * sx, sy * cx, -sy * sx];
        assert!((tilt_deg(yawed_roll) - roll.to_degrees()).abs() < 1e-9);
        assert!((tilt_deg(pitched_roll) - (pitch.cos() * roll.cos()).acos().to_degrees()).abs() < 1e-9);
        assert!(tilt_deg([sz, 0.0, 0.0, cz]) < 1e-9);
        assert!((tilt_deg([0.0, 1.0, 0.0, 0.0]) - 180.0).abs() < 1e-9);
        assert!(tilt_deg([0.0; 4]).is_nan());
    }

    #[test]
    fn tracking_measures_the_distance_from_the_leg_between_the_last_two_targets() {
        let mut tracking = Tracking::default();
        tracking.on_position([1.0, 1.0, 0.0]);
        assert_eq!(tracking.max_m(), None, "no leg before two targets");
        tracking.on_setpoint(Some([0.0, 0.0, -10.0]));
        tracking.on_setpoint(Some([40.0, 0.0, -10.0]));
        // 3 m east of the leg, 4 m below it: 5 m; beyond its end the distance is to the end.
        tracking.on_position([20.0, 3.0, -6.0]);
        tracking.on_position([43.0, 0.0, -6.0]);
        assert_eq!(tracking.max_m(), Some(5.0));
        assert!((tracking.rms_m().unwrap() - 5.0).abs() < 1e-12);
        // A repeated target keeps the leg; anything but a position target ends it.
        tracking.on_setpoint(Some([40.0, 0.0, -10.0]));
        tracking.on_position([20.0, 0.0, -10.0]);
        assert!((tracking.rms_m().unwrap() - (50.0f64 / 3.0).sqrt()).abs() < 1e-12);
        tracking.on_setpoint(None);
        tracking.on_position([0.0, 100.0, 0.0]);
        assert_eq!(tracking.max_m(), Some(5.0));
    }

    fn truth_at_us(us: u64, north_m: f64) -> GroundTruth {
        GroundTruth {
            time: Time::from_micros(us),
            position_ned_m: [north_m, 0.0, 0.0],
            lat_deg: north_m,
            ..Default::default()
        }
    }

    #[test]
    fn truth_at_an_instant_between_samples_is_interpolated_and_outside_the_window_is_none() {
        let window: VecDeque<GroundTruth> = [truth_at_us(1_000, 0.0), truth_at_us(3_000, 4.0)].into();
        assert_eq!(truth_at(&window, Time::from_micros(3_000)), Some(truth_at_us(3_000, 4.0)));
        let mid = truth_at(&window, Time::from_micros(1_500)).unwrap();
        assert_eq!((mid.time, mid.position_ned_m[0], mid.lat_deg), (Time::from_micros(1_500), 1.0, 1.0));
        assert_eq!(truth_at(&window, Time::from_micros(500)), None);
        assert_eq!(truth_at(&window, Time::from_micros(3_500)), None);
    }

    #[test]
    fn estimate_errors_are_root_mean_squares_over_the_samples() {
        let mut sums = ErrorSums::default();
        assert_eq!(sums.section(), None);
        let truth = GroundTruth::default();
        let level = [1.0, 0.0, 0.0, 0.0];
        let mut nav = NavState::exact(Time::ZERO, level, [0.0; 3], [0.0; 3], [3.0, 4.0, 1.0]);
        sums.add(&nav, &truth, [0.0; 3]);
        nav.position_ned_m = [0.0, 0.0, 1.0];
        sums.add(&nav, &truth, [0.0; 3]);
        let section = sums.section().unwrap();
        assert!((section.rms_horizontal_m - (25.0f64 / 2.0).sqrt()).abs() < 1e-12);
        assert_eq!((section.rms_vertical_m, section.max_horizontal_m, section.samples), (1.0, 5.0, 2));
        assert_eq!(
            (section.rms_roll_pitch_deg, section.rms_yaw_deg, section.rms_velocity_m_s),
            (0.0, 0.0, 0.0)
        );
    }

    #[test]
    fn the_airborne_path_counts_from_take_off_and_the_touchdown_is_the_last_airborne_sample() {
        let mut path = AirbornePath::default();
        let at = |north_m: f64, landed: bool, down_m_s: f64| GroundTruth {
            position_ned_m: [north_m, 0.0, 0.0],
            velocity_ned_m_s: [0.0, 0.0, down_m_s],
            landed,
            ..Default::default()
        };
        path.on_truth(&at(-5.0, true, 0.0));
        assert_eq!((path.length_m, path.straight_line_m(), path.touchdown), (0.0, 0.0, None));
        for (north_m, down_m_s) in [(0.0, -1.0), (3.0, 0.0), (1.0, 0.5)] {
            path.on_truth(&at(north_m, false, down_m_s));
        }
        path.on_truth(&at(1.0, true, 0.0));
        assert_eq!((path.length_m, path.straight_line_m()), (5.0, 1.0));
        assert_eq!(path.touchdown, Some(Touchdown { speed_down_m_s: 0.5, tilt_deg: 0.0 }));
    }

    #[test]
    fn a_limiting_cap_counts_until_the_next_status_per_reason() {
        let cap = |cap_m_s: f64, reason: ClearRangeReason, limiting: bool| {
            Some(SpeedCapStatus { cap_m_s, range_m: 5.0, reason, limiting })
        };
        let mut tally = SpeedCapTally::default();
        let s = Time::from_secs_f64;
        tally.on_status(s(1.0), cap(2.0, ClearRangeReason::Obstacle, true));
        tally.on_status(s(1.5), cap(3.0, ClearRangeReason::Obstacle, false));
        tally.on_status(s(2.0), cap(1.0, ClearRangeReason::Stale, true));
        tally.on_status(s(4.0), None);
        tally.on_status(s(9.0), None);
        let expected: BTreeMap<String, f64> =
            [("obstacle".to_owned(), 0.5), ("stale".to_owned(), 2.0)].into();
        assert_eq!(tally.by_reason, expected);
        assert_eq!(tally.lowest_m_s, Some(1.0));
    }
}
