//! Replay of a PX4 ULog through the EKF, compared with the log's own EKF2 output (and with
//! ground truth where a simulator logged it). I/O lives here, never in the filter core.
//!
//! Inputs: `sensor_combined` (IMU), `vehicle_gps_position` (or `sensor_gps`),
//! `vehicle_air_data` (barometer), `vehicle_magnetometer`. PX4 stamps GPS with its arrival, so
//! the replay subtracts the log's `EKF2_GPS_DELAY` (likewise `EKF2_BARO_DELAY`,
//! `EKF2_MAG_DELAY`) and runs the filter with those lags; the magnetic declination comes from
//! the log's `EKF2_MAG_DECL` when present. Every other setting comes from the caller's
//! [`EkfParams`].
//!
//! References: `vehicle_attitude` and `vehicle_local_position` (PX4 EKF2),
//! `vehicle_attitude_groundtruth` (SITL).

mod ulog;

pub use ulog::UlogDamage;

use std::io::Write;
use std::path::{Path, PathBuf};

use kestrel_proto::Time;
use kestrel_proto::attitude::{euler_rad, unit_quaternion, wxyz};
use kestrel_proto::geo::{Geodetic, LocalFrame, deg_from_e7};
use kestrel_proto::messages::{BaroSample, GpsFix, GpsFixType, ImuSample, MagSample};
use nalgebra::{UnitQuaternion, Vector3};

use crate::ekf::Ekf;
use crate::error::ParamError;
use crate::params::EkfParams;
use ulog::Log;

/// Why a replay could not run.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    #[error("log path {path:?} is not valid UTF-8")]
    Path { path: PathBuf },
    #[error("cannot read ULog {path:?}: {source}")]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path:?} is not a ULog (it does not start with the ULog magic; {bytes} bytes)")]
    NotUlog { path: PathBuf, bytes: u64 },
    #[error("ULog {path:?} lacks topic `{topic}`{}", field.as_ref().map(|f| format!(" field `{f}`")).unwrap_or_default())]
    Missing { path: PathBuf, topic: String, field: Option<String> },
    #[error("ULog {path:?} has no usable IMU samples")]
    NoImu { path: PathBuf },
    #[error("the estimator never aligned on {path:?} (the vehicle was never still)")]
    NeverAligned { path: PathBuf },
    #[error(transparent)]
    Params(#[from] ParamError),
}

/// One comparison instant (a `vehicle_attitude` sample of the log).
#[derive(Clone, Debug, PartialEq)]
pub struct ReplayRow {
    /// Log time (s since boot).
    pub time_s: f64,
    /// Our roll, pitch, yaw (degrees).
    pub ours_rpy_deg: [f64; 3],
    /// EKF2's roll, pitch, yaw (degrees).
    pub px4_rpy_deg: [f64; 3],
    /// Our position north, east, down (m): north/east in EKF2's local frame when both hold a
    /// valid GPS position, else in ours; down shifted to agree with EKF2 at the first instant
    /// both have a height.
    pub ours_ned_m: [f64; 3],
    /// EKF2's local position (m), when logged near this instant.
    pub px4_ned_m: Option<[f64; 3]>,
    /// Whether both filters hold a valid horizontal position.
    pub horizontal_valid: bool,
    /// Ground-truth roll, pitch, yaw (degrees), from a simulator log.
    pub truth_rpy_deg: Option<[f64; 3]>,
    /// Rotation angle between our attitude and ground truth (degrees).
    pub truth_angle_deg: Option<f64>,
}

/// RMS differences over a replay.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReplaySummary {
    pub rows: usize,
    /// Log time at which our filter aligned (s).
    pub aligned_at_s: f64,
    pub rms_roll_vs_px4_deg: f64,
    pub rms_pitch_vs_px4_deg: f64,
    pub rms_yaw_vs_px4_deg: f64,
    /// Height difference to EKF2 (m), where EKF2's height is valid.
    pub rms_height_vs_px4_m: Option<f64>,
    /// Horizontal difference to EKF2 (m), where both have a valid horizontal position.
    pub rms_horizontal_vs_px4_m: Option<f64>,
    /// Rotation angle to ground truth (degrees), from a simulator log.
    pub rms_attitude_vs_truth_deg: Option<f64>,
    /// Tilt (roll and pitch) difference to ground truth (degrees).
    pub rms_tilt_vs_truth_deg: Option<f64>,
}

/// A replay's rows and summary.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReplayResult {
    pub rows: Vec<ReplayRow>,
    pub summary: ReplaySummary,
    /// Where the log broke, when it did before its end: the replay covers what came before.
    pub log_damage: Option<UlogDamage>,
}

/// A sensor sample in arrival order.
enum Event {
    Imu(ImuSample),
    Gps(GpsFix),
    Baro(BaroSample),
    Mag(MagSample),
}

/// Our present estimate after one IMU sample.
struct TrackPoint {
    time_us: u64,
    attitude: UnitQuaternion<f64>,
    /// Position in our own NED frame (m).
    pos_ned_m: Vector3<f64>,
    /// The same point on WGS-84, once our frame has a GPS origin.
    geodetic: Option<Geodetic>,
    horizontal_valid: bool,
}

/// Runs the EKF over the ULog at `path` and compares with the log's EKF2 (see the module doc).
pub fn replay_ulog(path: &Path, params: &EkfParams) -> Result<ReplayResult, ReplayError> {
    let log = Log::read(path)?;
    let mut params = params.clone();
    if let Some(d) = log.param("EKF2_GPS_DELAY") {
        params.gps_lag_s = d * 1e-3;
    }
    if let Some(d) = log.param("EKF2_BARO_DELAY") {
        params.baro_lag_s = d * 1e-3;
    }
    if let Some(d) = log.param("EKF2_MAG_DELAY") {
        params.mag_lag_s = d * 1e-3;
    }
    if let Some(decl) = log.param("EKF2_MAG_DECL") {
        params.mag_declination_deg = decl;
    }
    let events = read_events(&log, path, &params)?;
    let mut ekf = Ekf::new(params)?;
    let mut track = Vec::with_capacity(events.len());
    for (_, event) in &events {
        let result = match event {
            Event::Imu(s) => ekf.push_imu(s),
            Event::Gps(f) => ekf.push_gps(f),
            Event::Baro(b) => ekf.push_baro(b),
            Event::Mag(m) => ekf.push_mag(m),
        };
        if let Err(e) = result {
            tracing::debug!("replay sample refused: {e}");
        }
        if let (Event::Imu(_), Some(nav)) = (event, ekf.nav_state())
            && let Ok(attitude) = unit_quaternion(nav.attitude)
        {
            track.push(TrackPoint {
                time_us: nav.time.as_micros(),
                attitude,
                pos_ned_m: Vector3::from(nav.position_ned_m),
                geodetic: ekf.frame().map(|frame| frame.to_geodetic(nav.position_ned_m)),
                horizontal_valid: nav.valid.horizontal_position,
            });
        }
    }
    if track.is_empty() {
        return Err(ReplayError::NeverAligned { path: path.to_owned() });
    }
    let mut result = compare(&log, &track)?;
    result.log_damage = log.ended_early().cloned();
    Ok(result)
}

fn read_events(log: &Log, path: &Path, params: &EkfParams) -> Result<Vec<(u64, Event)>, ReplayError> {
    let mut events = Vec::new();
    let imu_t = log.times_us("sensor_combined")?;
    let gyro = log.vec3("sensor_combined", "gyro_rad")?;
    let accel = log.vec3("sensor_combined", "accelerometer_m_s2")?;
    let dt = log.column("sensor_combined", "gyro_integral_dt")?;
    let mut last = None;
    for i in 0..imu_t.len() {
        let t = imu_t[i];
        // PX4 logged the interval in seconds (float) before v1.9 and in µs since.
        let dt_s = match (dt[i], last) {
            (d, _) if d > 0.0 && d < 1.0 => d,
            (d, _) if d >= 1.0 => d * 1e-6,
            (_, Some(prev)) => (t - prev) as f64 * 1e-6,
            _ => continue,
        };
        last = Some(t);
        // `sensor_combined` carries clipping only as a separate counter topic; read as unclipped.
        let s = ImuSample {
            time: Time::from_micros(t),
            gyro_rad_s: gyro[i],
            accel_m_s2: accel[i],
            dt_s,
            gyro_clipped: [false; 3],
            accel_clipped: [false; 3],
        };
        events.push((t, Event::Imu(s)));
    }
    if events.is_empty() {
        return Err(ReplayError::NoImu { path: path.to_owned() });
    }
    let gps_topic = ["vehicle_gps_position", "sensor_gps"].into_iter().find(|t| log.has(t));
    if let Some(topic) = gps_topic {
        read_gps(log, topic, params, &mut events)?;
    }
    if log.has("vehicle_air_data") {
        let t = log.sample_times_us("vehicle_air_data")?;
        let alt = log.column("vehicle_air_data", "baro_alt_meter")?;
        let lag_us = (params.baro_lag_s * 1e6) as u64;
        for (t, alt) in t.into_iter().zip(alt) {
            let s = BaroSample {
                time: Time::from_micros(t.saturating_sub(lag_us)),
                pressure_pa: 0.0,
                altitude_m: alt,
                temperature_c: 0.0,
            };
            events.push((t, Event::Baro(s)));
        }
    }
    if log.has("vehicle_magnetometer") {
        let t = log.sample_times_us("vehicle_magnetometer")?;
        let field = log.vec3("vehicle_magnetometer", "magnetometer_ga")?;
        let lag_us = (params.mag_lag_s * 1e6) as u64;
        for (t, field) in t.into_iter().zip(field) {
            let s = MagSample { time: Time::from_micros(t.saturating_sub(lag_us)), field_gauss: field };
            events.push((t, Event::Mag(s)));
        }
    }
    events.sort_by_key(|(t, _)| *t);
    Ok(events)
}

fn read_gps(
    log: &Log,
    topic: &str,
    params: &EkfParams,
    events: &mut Vec<(u64, Event)>,
) -> Result<(), ReplayError> {
    let t = log.times_us(topic)?;
    let (lat_kind, lat) = log.column_any(topic, &["latitude_deg", "lat"])?;
    let (_, lon) = log.column_any(topic, &["longitude_deg", "lon"])?;
    let (alt_kind, alt) = log.column_any(topic, &["altitude_msl_m", "alt"])?;
    let vn = log.column(topic, "vel_n_m_s")?;
    let ve = log.column(topic, "vel_e_m_s")?;
    let vd = log.column(topic, "vel_d_m_s")?;
    let eph = log.column(topic, "eph")?;
    let epv = log.column(topic, "epv")?;
    let s_acc = log.column(topic, "s_variance_m_s")?;
    let fix = log.column(topic, "fix_type")?;
    let sats = log.column(topic, "satellites_used")?;
    // Older logs carry degrees ×1e7 and millimetres as integers.
    let degrees = |v: f64| if lat_kind == 0 { v } else { deg_from_e7(v) };
    let alt_scale = if alt_kind == 0 { 1.0 } else { 1e-3 };
    let lag_us = (params.gps_lag_s * 1e6) as u64;
    for i in 0..t.len() {
        let fix_type = match fix[i] as u8 {
            0 | 1 => GpsFixType::NoFix,
            2 => GpsFixType::Fix2d,
            3 => GpsFixType::Fix3d,
            4 => GpsFixType::Dgps,
            5 => GpsFixType::RtkFloat,
            _ => GpsFixType::RtkFixed,
        };
        let f = GpsFix {
            time: Time::from_micros(t[i].saturating_sub(lag_us)),
            fix_type,
            satellites: sats[i].clamp(0.0, 255.0) as u8,
            lat_deg: degrees(lat[i]),
            lon_deg: degrees(lon[i]),
            alt_msl_m: alt[i] * alt_scale,
            vel_ned_m_s: [vn[i], ve[i], vd[i]],
            h_acc_m: eph[i],
            v_acc_m: epv[i],
            s_acc_m_s: s_acc[i],
        };
        events.push((t[i], Event::Gps(f)));
    }
    Ok(())
}

fn nearest<'a, T>(times: &[u64], items: &'a [T], t: u64, max_gap_us: u64) -> Option<&'a T> {
    let i = times.partition_point(|&x| x < t);
    let candidates = [i.checked_sub(1), (i < times.len()).then_some(i)];
    candidates
        .into_iter()
        .flatten()
        .filter(|&k| times[k].abs_diff(t) <= max_gap_us)
        .min_by_key(|&k| times[k].abs_diff(t))
        .map(|k| &items[k])
}

fn rpy_deg(q: &UnitQuaternion<f64>) -> [f64; 3] {
    euler_rad(wxyz(q)).map(f64::to_degrees)
}

fn wrap_deg(a: f64) -> f64 {
    (a + 180.0).rem_euclid(360.0) - 180.0
}

fn compare(log: &Log, track: &[TrackPoint]) -> Result<ReplayResult, ReplayError> {
    let track_t: Vec<u64> = track.iter().map(|p| p.time_us).collect();
    let att_t = log.sample_times_us("vehicle_attitude")?;
    let att_q = log.vec4("vehicle_attitude", "q")?;
    let truth = if log.has("vehicle_attitude_groundtruth") {
        Some((
            log.sample_times_us("vehicle_attitude_groundtruth")?,
            log.vec4("vehicle_attitude_groundtruth", "q")?,
        ))
    } else {
        None
    };
    let local = if log.has("vehicle_local_position") {
        let topic = "vehicle_local_position";
        let t = log.sample_times_us(topic)?;
        let x = log.column(topic, "x")?;
        let y = log.column(topic, "y")?;
        let z = log.column(topic, "z")?;
        let xy_valid = log.column(topic, "xy_valid")?;
        let z_valid = log.column(topic, "z_valid")?;
        let xy_global = log.column(topic, "xy_global")?;
        let ref_lat = log.column(topic, "ref_lat")?;
        let ref_lon = log.column(topic, "ref_lon")?;
        let ref_alt = log.column(topic, "ref_alt")?;
        let rows: Vec<_> = (0..t.len())
            .map(|i| {
                let frame = (xy_global[i] > 0.5).then(|| {
                    LocalFrame::new(Geodetic { lat_deg: ref_lat[i], lon_deg: ref_lon[i], alt_m: ref_alt[i] })
                });
                ([x[i], y[i], z[i]], xy_valid[i] > 0.5, z_valid[i] > 0.5, frame)
            })
            .collect();
        Some((t, rows))
    } else {
        None
    };

    let mut rows = Vec::new();
    let mut height_offset: Option<f64> = None;
    for (&t, &q) in att_t.iter().zip(&att_q) {
        let Some(ours) = nearest(&track_t, track, t, 10_000) else { continue };
        // EKF2 logs a zero quaternion before it has aligned: no comparison there.
        let Ok(px4_q) = unit_quaternion(q) else { continue };
        let px4_local = local.as_ref().and_then(|(lt, lrows)| nearest(lt, lrows, t, 100_000));
        let (ours_ne, horizontal_valid) = match (px4_local, ours.geodetic) {
            (Some((_, true, _, Some(frame))), Some(g)) if ours.horizontal_valid => {
                let p = frame.to_ned(g);
                ([p[0], p[1]], true)
            }
            _ => ([ours.pos_ned_m.x, ours.pos_ned_m.y], false),
        };
        let down = ours.pos_ned_m.z;
        let px4_ned = px4_local.map(|(p, ..)| *p);
        let px4_z_valid = px4_local.is_some_and(|(_, _, zv, _)| *zv);
        let offset = match (px4_ned, px4_z_valid) {
            (Some(p), true) => *height_offset.get_or_insert(p[2] - down),
            _ => height_offset.unwrap_or(0.0),
        };
        let ours_ned_m = [ours_ne[0], ours_ne[1], down + offset];
        let truth_q = truth
            .as_ref()
            .and_then(|(tt, tq)| nearest(tt, tq, t, 20_000))
            .and_then(|q| unit_quaternion(*q).ok());
        rows.push(ReplayRow {
            time_s: t as f64 * 1e-6,
            ours_rpy_deg: rpy_deg(&ours.attitude),
            px4_rpy_deg: rpy_deg(&px4_q),
            ours_ned_m,
            px4_ned_m: px4_ned.filter(|_| px4_z_valid),
            horizontal_valid,
            truth_rpy_deg: truth_q.as_ref().map(rpy_deg),
            truth_angle_deg: truth_q.map(|tq| ours.attitude.angle_to(&tq).to_degrees()),
        });
    }
    let summary = summarise(&rows, track[0].time_us as f64 * 1e-6);
    Ok(ReplayResult { rows, summary, log_damage: None })
}

fn rms(values: impl Iterator<Item = f64>) -> Option<f64> {
    let (sum, n) = values.fold((0.0, 0usize), |(s, n), v| (s + v * v, n + 1));
    (n > 0).then(|| (sum / n as f64).sqrt())
}

fn summarise(rows: &[ReplayRow], aligned_at_s: f64) -> ReplaySummary {
    let diff = |k: usize| {
        rms(rows.iter().map(|r| wrap_deg(r.ours_rpy_deg[k] - r.px4_rpy_deg[k]))).unwrap_or(f64::NAN)
    };
    ReplaySummary {
        rows: rows.len(),
        aligned_at_s,
        rms_roll_vs_px4_deg: diff(0),
        rms_pitch_vs_px4_deg: diff(1),
        rms_yaw_vs_px4_deg: diff(2),
        rms_height_vs_px4_m: rms(rows.iter().filter_map(|r| r.px4_ned_m.map(|p| r.ours_ned_m[2] - p[2]))),
        rms_horizontal_vs_px4_m: rms(rows
            .iter()
            .filter(|r| r.horizontal_valid)
            .filter_map(|r| r.px4_ned_m.map(|p| (r.ours_ned_m[0] - p[0]).hypot(r.ours_ned_m[1] - p[1])))),
        rms_attitude_vs_truth_deg: rms(rows.iter().filter_map(|r| r.truth_angle_deg)),
        rms_tilt_vs_truth_deg: rms(rows.iter().filter_map(|r| {
            r.truth_rpy_deg
                .map(|t| (wrap_deg(r.ours_rpy_deg[0] - t[0])).hypot(wrap_deg(r.ours_rpy_deg[1] - t[1])))
        })),
    }
}

/// Writes the rows as CSV with a header line: ours beside EKF2's (and ground truth's).
pub fn write_csv(result: &ReplayResult, mut out: impl Write) -> std::io::Result<()> {
    writeln!(
        out,
        "time_s,roll_deg,pitch_deg,yaw_deg,px4_roll_deg,px4_pitch_deg,px4_yaw_deg,north_m,east_m,down_m,\
         px4_north_m,px4_east_m,px4_down_m,truth_roll_deg,truth_pitch_deg,truth_yaw_deg"
    )?;
    let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.4}"));
    for r in &result.rows {
        let px4 = r.px4_ned_m;
        let truth = r.truth_rpy_deg;
        writeln!(
            out,
            "{:.6},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{},{},{:.4},{},{},{},{},{},{}",
            r.time_s,
            r.ours_rpy_deg[0],
            r.ours_rpy_deg[1],
            r.ours_rpy_deg[2],
            r.px4_rpy_deg[0],
            r.px4_rpy_deg[1],
            r.px4_rpy_deg[2],
            opt(Some(r.ours_ned_m[0])),
            opt(Some(r.ours_ned_m[1])),
            r.ours_ned_m[2],
            opt(px4.map(|p| p[0])),
            opt(px4.map(|p| p[1])),
            opt(px4.map(|p| p[2])),
            opt(truth.map(|t| t[0])),
            opt(truth.map(|t| t[1])),
            opt(truth.map(|t| t[2])),
        )?;
    }
    Ok(())
}
