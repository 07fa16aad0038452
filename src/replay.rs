//! The estimator replayed over a flight log: our EKF runs on the log's sensor samples in the
//! order the vehicle received them, and its estimate is set beside the log's own (PX4 EKF2's,
//! or the recorded `nav_state`) and beside ground truth where a simulator logged it. Behind
//! `kestrel replay`; the log is read by [`FlightLog`], as the `log_replay` actor reads it.
//!
//! One row per instant of the primary reference — ground truth when it has positions (our
//! simulator), else the log's estimate — with our estimate nearest that instant. Positions are
//! in our filter's NED frame; a reference's height is shifted by a constant where it keeps its
//! own datum ([`Reference::align_height`]).

use std::io::Write;
use std::path::PathBuf;

use kestrel_estimator::{Ekf, EkfParams, ParamError};
use kestrel_proto::Time;
use kestrel_proto::attitude::{euler_rad, unit_quaternion, wxyz};
use kestrel_proto::geo::{Geodetic, LocalFrame};

use crate::flight_log::{FlightLog, Kind, Place, Reference, ReferenceSample, Replayed, nearest};

/// Why a replay could not run.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    #[error("flight log {}: no IMU samples, the estimator cannot run", path.display())]
    NoImu { path: PathBuf },
    #[error("flight log {}: neither an estimate nor ground truth is logged to compare with", path.display())]
    NoReference { path: PathBuf },
    #[error("the estimator never aligned on {} (the vehicle was never still)", path.display())]
    NeverAligned { path: PathBuf },
    #[error(transparent)]
    Params(#[from] ParamError),
}

/// Our estimate beside a reference at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Beside {
    pub rpy_deg: Option<[f64; 3]>,
    /// Rotation angle from our attitude (degrees).
    pub angle_deg: Option<f64>,
    /// North, east, down in our frame (m); down shifted into our datum where the reference
    /// keeps its own.
    pub ned_m: Option<[f64; 3]>,
    pub horizontal_valid: bool,
    pub vertical_valid: bool,
}

/// One comparison instant.
#[derive(Clone, Debug, PartialEq)]
pub struct ReplayRow {
    /// Log time (s).
    pub time_s: f64,
    pub rpy_deg: [f64; 3],
    /// Our position north, east, down in our frame (m).
    pub ned_m: [f64; 3],
    pub horizontal_valid: bool,
    pub vertical_valid: bool,
    /// The log's own estimate (EKF2, the recorded nav_state).
    pub estimate: Option<Beside>,
    pub truth: Option<Beside>,
}

/// RMS differences to one reference over a replay.
#[derive(Clone, Debug, PartialEq)]
pub struct Scores {
    pub label: &'static str,
    pub rows: usize,
    pub rms_roll_deg: Option<f64>,
    pub rms_pitch_deg: Option<f64>,
    pub rms_yaw_deg: Option<f64>,
    /// Whole-attitude rotation angle (degrees).
    pub rms_attitude_deg: Option<f64>,
    /// Roll and pitch together (degrees).
    pub rms_tilt_deg: Option<f64>,
    /// Where both hold a valid height (m).
    pub rms_height_m: Option<f64>,
    /// Where both hold a valid horizontal position (m).
    pub rms_horizontal_m: Option<f64>,
}

/// A replay's summary.
#[derive(Clone, Debug, PartialEq)]
pub struct ReplaySummary {
    pub rows: usize,
    /// What the rows are at.
    pub primary: &'static str,
    /// Log time at which our filter aligned (s).
    pub aligned_at_s: f64,
    /// Samples the estimator refused.
    pub rejected: u64,
    pub vs_estimate: Option<Scores>,
    pub vs_truth: Option<Scores>,
}

/// A replay's rows and summary.
#[derive(Clone, Debug, PartialEq)]
pub struct Replay {
    pub rows: Vec<ReplayRow>,
    pub summary: ReplaySummary,
    /// Where the log broke, when it did before its end: the replay covers what came before.
    pub log_damage: Option<String>,
}

/// Our estimate after one IMU sample.
struct TrackPoint {
    time: Time,
    /// Body-to-NED `[w, x, y, z]`, of unit norm.
    attitude: [f64; 4],
    ned_m: [f64; 3],
    /// The same point on WGS-84, once our frame has a GPS origin.
    geodetic: Option<Geodetic>,
    horizontal_valid: bool,
    vertical_valid: bool,
}

/// The longest gap (µs) between a reference instant and the estimate set beside it: our
/// filter's estimates come at the IMU rate, so this is a few IMU periods.
const OURS_GAP_US: u64 = 10_000;
/// The longest gap (µs) between the primary reference's instant and the other reference's.
const OTHER_REFERENCE_GAP_US: u64 = 20_000;

/// Runs a fresh EKF (with `params`, overridden by what the log recorded) over `log`.
pub fn replay(log: &FlightLog, params: EkfParams) -> Result<Replay, ReplayError> {
    let path = || log.path().to_owned();
    let (estimate, truth) = log.references();
    let truth_has_positions = truth.is_some_and(|t| t.samples.iter().any(|s| s.position.is_some()));
    let primary = match (estimate, truth) {
        (_, Some(t)) if truth_has_positions => t,
        (Some(e), _) => e,
        (None, Some(t)) => t,
        (None, None) => return Err(ReplayError::NoReference { path: path() }),
    };
    let mut events: Vec<(Time, &Replayed)> = Vec::new();
    for topic in log.sensors() {
        // One topic per kind: a log with two IMUs replays the first, as the vehicle flew on it.
        if log.sensors().iter().find(|t| t.kind == topic.kind).is_some_and(|first| first.name == topic.name) {
            events.extend(topic.samples.iter().map(|(t, m)| (*t, m)));
        }
    }
    if !log.sensors().iter().any(|t| t.kind == Kind::Imu && !t.samples.is_empty()) {
        return Err(ReplayError::NoImu { path: path() });
    }
    events.sort_by_key(|(t, _)| *t);

    let mut ekf = Ekf::new(log.settings().apply(params))?;
    let mut track = Vec::with_capacity(events.len());
    let mut rejected = 0;
    for (_, event) in events {
        let result = match event {
            Replayed::Imu(s) => ekf.push_imu(s),
            Replayed::Gps(f) => ekf.push_gps(f),
            Replayed::Baro(b) => ekf.push_baro(b),
            Replayed::Mag(m) => ekf.push_mag(m),
            Replayed::Battery(_) => Ok(()),
        };
        if let Err(e) = result {
            rejected += 1;
            tracing::debug!("replay sample refused: {e}");
        }
        if let (Replayed::Imu(_), Some(nav)) = (event, ekf.nav_state())
            && let Ok(attitude) = unit_quaternion(nav.attitude)
        {
            track.push(TrackPoint {
                time: nav.time,
                attitude: wxyz(&attitude),
                ned_m: nav.position_ned_m,
                geodetic: ekf.frame().map(|frame| frame.to_geodetic(nav.position_ned_m)),
                horizontal_valid: nav.valid.horizontal_position,
                vertical_valid: nav.valid.vertical_position,
            });
        }
    }
    let Some(first) = track.first() else { return Err(ReplayError::NeverAligned { path: path() }) };
    let aligned_at_s = first.time.as_secs_f64();
    let frame = ekf.frame().copied();
    let mut offsets = HeightOffsets::default();
    let mut rows = Vec::new();
    for sample in &primary.samples {
        let t = sample.time.as_micros();
        let Some(ours) = nearest(&track, |p| p.time, t, OURS_GAP_US) else { continue };
        let beside = |reference: Option<&Reference>, slot: usize, offsets: &mut HeightOffsets| {
            let reference = reference?;
            let found = if std::ptr::eq(reference, primary) {
                Some(sample)
            } else {
                nearest(&reference.samples, |s| s.time, t, OTHER_REFERENCE_GAP_US)
            }?;
            Some(set_beside(ours, found, reference.align_height, frame.as_ref(), &mut offsets.0[slot]))
        };
        let estimate_beside = beside(estimate, 0, &mut offsets);
        let truth_beside = beside(truth, 1, &mut offsets);
        rows.push(ReplayRow {
            time_s: sample.time.as_secs_f64(),
            rpy_deg: rpy_deg(ours.attitude),
            ned_m: ours.ned_m,
            horizontal_valid: ours.horizontal_valid,
            vertical_valid: ours.vertical_valid,
            estimate: estimate_beside,
            truth: truth_beside,
        });
    }
    let summary = ReplaySummary {
        rows: rows.len(),
        primary: primary.label,
        aligned_at_s,
        rejected,
        vs_estimate: estimate.map(|r| scores(r.label, &rows, |row| row.estimate.as_ref())),
        vs_truth: truth.map(|r| scores(r.label, &rows, |row| row.truth.as_ref())),
    };
    Ok(Replay { rows, summary, log_damage: log.damage().map(str::to_owned) })
}

/// Per reference, the height difference removed where it keeps its own datum, fixed at the
/// first instant both heights are valid.
#[derive(Default)]
struct HeightOffsets([Option<f64>; 2]);

fn set_beside(
    ours: &TrackPoint,
    sample: &ReferenceSample,
    align_height: bool,
    frame: Option<&LocalFrame>,
    offset: &mut Option<f64>,
) -> Beside {
    let attitude = sample.attitude.and_then(|q| unit_quaternion(q).ok()).map(|q| wxyz(&q));
    let position = sample.position.map(|p| {
        let mut ned = match (p.place, frame) {
            (Place::Local { ned_m, origin: Some(origin) }, Some(frame)) => {
                frame.to_ned(LocalFrame::new(origin).to_geodetic(ned_m))
            }
            (Place::Local { ned_m, .. }, _) => ned_m,
            (Place::Global(g), Some(frame)) => frame.to_ned(g),
            // Truth on WGS-84 with no frame of ours to put it in yet.
            (Place::Global(_), None) => [f64::NAN; 3],
        };
        if align_height {
            // Its own height in its own datum, shifted by the difference at the first instant
            // both heights are valid.
            let own_down = match p.place {
                Place::Local { ned_m, .. } => ned_m[2],
                Place::Global(_) => ned[2],
            };
            let shift = if p.vertical_valid {
                *offset.get_or_insert(own_down - ours.ned_m[2])
            } else {
                offset.unwrap_or(0.0)
            };
            ned[2] = own_down - shift;
        }
        let finite = ned.iter().all(|x| x.is_finite());
        let horizontal_valid =
            p.horizontal_valid && finite && ours.geodetic.is_some() && ours.horizontal_valid;
        (finite.then_some(ned), horizontal_valid, p.vertical_valid && finite)
    });
    let (ned_m, horizontal_valid, vertical_valid) = position.unwrap_or((None, false, false));
    Beside {
        rpy_deg: attitude.map(rpy_deg),
        angle_deg: attitude.and_then(|q| angle_deg(ours.attitude, q)),
        ned_m,
        horizontal_valid,
        vertical_valid,
    }
}

fn scores(label: &'static str, rows: &[ReplayRow], pick: impl Fn(&ReplayRow) -> Option<&Beside>) -> Scores {
    let with: Vec<(&ReplayRow, &Beside)> = rows.iter().filter_map(|r| pick(r).map(|b| (r, b))).collect();
    let axis =
        |k: usize| rms(with.iter().filter_map(|(r, b)| b.rpy_deg.map(|e| wrap_deg(r.rpy_deg[k] - e[k]))));
    Scores {
        label,
        rows: with.len(),
        rms_roll_deg: axis(0),
        rms_pitch_deg: axis(1),
        rms_yaw_deg: axis(2),
        rms_attitude_deg: rms(with.iter().filter_map(|(_, b)| b.angle_deg)),
        rms_tilt_deg: rms(with.iter().filter_map(|(r, b)| {
            b.rpy_deg.map(|e| wrap_deg(r.rpy_deg[0] - e[0]).hypot(wrap_deg(r.rpy_deg[1] - e[1])))
        })),
        rms_height_m: rms(with
            .iter()
            .filter(|(_, b)| b.vertical_valid)
            .filter_map(|(r, b)| b.ned_m.map(|p| r.ned_m[2] - p[2]))),
        rms_horizontal_m: rms(with
            .iter()
            .filter(|(_, b)| b.horizontal_valid)
            .filter_map(|(r, b)| b.ned_m.map(|p| (r.ned_m[0] - p[0]).hypot(r.ned_m[1] - p[1])))),
    }
}

fn rpy_deg(q: [f64; 4]) -> [f64; 3] {
    euler_rad(q).map(f64::to_degrees)
}

/// The rotation angle between two attitudes (degrees).
fn angle_deg(a: [f64; 4], b: [f64; 4]) -> Option<f64> {
    Some(unit_quaternion(a).ok()?.angle_to(&unit_quaternion(b).ok()?).to_degrees())
}

fn wrap_deg(a: f64) -> f64 {
    (a + 180.0).rem_euclid(360.0) - 180.0
}

fn rms(values: impl Iterator<Item = f64>) -> Option<f64> {
    let (sum, n) = values.fold((0.0, 0usize), |(s, n), v| (s + v * v, n + 1));
    (n > 0).then(|| (sum / n as f64).sqrt())
}

/// The header of [`write_csv`]'s table.
pub const CSV_HEADER: &str = "time_s,roll_deg,pitch_deg,yaw_deg,north_m,east_m,down_m,\
    ref_roll_deg,ref_pitch_deg,ref_yaw_deg,ref_north_m,ref_east_m,ref_down_m,\
    truth_roll_deg,truth_pitch_deg,truth_yaw_deg,truth_north_m,truth_east_m,truth_down_m";

/// Writes the rows as CSV: ours, then the log's estimate (`ref_`), then ground truth
/// (`truth_`); a cell is empty where that reference holds nothing at that instant.
pub fn write_csv(replay: &Replay, mut out: impl Write) -> std::io::Result<()> {
    writeln!(out, "{CSV_HEADER}")?;
    let cells = |b: Option<&Beside>| {
        let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.4}"));
        let rpy = b.and_then(|b| b.rpy_deg);
        let ned = b.and_then(|b| b.ned_m);
        (0..3)
            .map(|k| opt(rpy.map(|a| a[k])))
            .chain((0..3).map(|k| opt(ned.map(|p| p[k]))))
            .collect::<Vec<_>>()
            .join(",")
    };
    for r in &replay.rows {
        writeln!(
            out,
            "{:.6},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{},{}",
            r.time_s,
            r.rpy_deg[0],
            r.rpy_deg[1],
            r.rpy_deg[2],
            r.ned_m[0],
            r.ned_m[1],
            r.ned_m[2],
            cells(r.estimate.as_ref()),
            cells(r.truth.as_ref()),
        )?;
    }
    Ok(())
}
