//! A PX4 ULog as a [`FlightLog`].
//!
//! Sensors: `sensor_combined` (IMU), `vehicle_gps_position` (or `sensor_gps`),
//! `vehicle_air_data` (barometer), `vehicle_magnetometer`. PX4 stamps GPS with its arrival and
//! leaves the lag to EKF2, so a fix is stamped here with its arrival minus the log's
//! `EKF2_GPS_DELAY` (likewise `EKF2_BARO_DELAY`, `EKF2_MAG_DELAY` from the sample time), and
//! those lags and `EKF2_MAG_DECL` are the log's [`LoggedSettings`]. A log that lacks one ran on
//! PX4's default: 110 ms for GPS, 0 for the others.
//!
//! References: EKF2's `vehicle_attitude` with the `vehicle_local_position` logged nearest it,
//! and, from PX4's SITL, `vehicle_attitude_groundtruth` (attitude only).

use std::path::Path;

use kestrel_proto::Time;
use kestrel_proto::geo::{Geodetic, deg_from_e7};
use kestrel_proto::messages::{BaroSample, GpsFix, GpsFixType, ImuSample, MagSample};

use super::ulog::Log;
use super::{
    FlightLog, FlightLogError, Format, Kind, LogTopic, LoggedSettings, Place, Reference, ReferencePosition,
    ReferenceSample, Replayed, SensorTopic, nearest,
};

/// The ULog topics read as sensors: IMU, GPS (the first of the two present), barometer,
/// magnetometer.
pub(super) const SENSOR_TOPICS: [&str; 5] =
    ["sensor_combined", "vehicle_gps_position", "sensor_gps", "vehicle_air_data", "vehicle_magnetometer"];

/// PX4's default `EKF2_GPS_DELAY` (ms).
const PX4_DEFAULT_GPS_DELAY_MS: f64 = 110.0;

/// The longest gap (µs) between an EKF2 attitude and the local position paired with it.
const LOCAL_POSITION_GAP_US: u64 = 100_000;

pub(super) fn read(path: &Path, bytes: &[u8]) -> Result<FlightLog, FlightLogError> {
    let log = Log::read(path, bytes)?;
    let ms = |name: &str, default: f64| Some(log.param(name).unwrap_or(default) * 1e-3);
    let settings = LoggedSettings {
        gps_lag_s: ms("EKF2_GPS_DELAY", PX4_DEFAULT_GPS_DELAY_MS),
        baro_lag_s: ms("EKF2_BARO_DELAY", 0.0),
        mag_lag_s: ms("EKF2_MAG_DELAY", 0.0),
        mag_declination_deg: Some(log.param("EKF2_MAG_DECL").unwrap_or(0.0)),
    };
    let mut sensors = Vec::new();
    if log.has("sensor_combined") {
        sensors.push(SensorTopic {
            name: "sensor_combined".to_owned(),
            kind: Kind::Imu,
            samples: imu(&log)?,
        });
    }
    if let Some(topic) = ["vehicle_gps_position", "sensor_gps"].into_iter().find(|t| log.has(t)) {
        let samples = gps(&log, topic, settings.gps_lag_s.unwrap_or_default())?;
        sensors.push(SensorTopic { name: topic.to_owned(), kind: Kind::Gps, samples });
    }
    if log.has("vehicle_air_data") {
        let samples = baro(&log, settings.baro_lag_s.unwrap_or_default())?;
        sensors.push(SensorTopic { name: "vehicle_air_data".to_owned(), kind: Kind::Baro, samples });
    }
    if log.has("vehicle_magnetometer") {
        let samples = mag(&log, settings.mag_lag_s.unwrap_or_default())?;
        sensors.push(SensorTopic { name: "vehicle_magnetometer".to_owned(), kind: Kind::Mag, samples });
    }
    let truth = if log.has("vehicle_attitude_groundtruth") {
        let t = log.sample_times_us("vehicle_attitude_groundtruth")?;
        let q = log.vec4("vehicle_attitude_groundtruth", "q")?;
        let samples = t
            .into_iter()
            .zip(q)
            .map(|(t, q)| ReferenceSample { time: Time::from_micros(t), attitude: Some(q), position: None })
            .collect();
        Some(Reference { label: "ground truth", samples, align_height: false })
    } else {
        None
    };
    Ok(FlightLog {
        path: path.to_owned(),
        format: Format::Ulog,
        topics: log.topic_names().map(|t| LogTopic { name: t.to_owned(), type_name: t.to_owned() }).collect(),
        sensors,
        estimate: if log.has("vehicle_attitude") { Some(ekf2(&log)?) } else { None },
        truth,
        settings,
        damage: log.ended_early().map(ToString::to_string),
    })
}

fn imu(log: &Log) -> Result<Vec<(Time, Replayed)>, FlightLogError> {
    let topic = "sensor_combined";
    let imu_t = log.times_us(topic)?;
    let gyro = log.vec3(topic, "gyro_rad")?;
    let accel = log.vec3(topic, "accelerometer_m_s2")?;
    let dt = log.column(topic, "gyro_integral_dt")?;
    let mut samples = Vec::with_capacity(imu_t.len());
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
        samples.push((Time::from_micros(t), Replayed::Imu(s)));
    }
    Ok(samples)
}

fn gps(log: &Log, topic: &str, lag_s: f64) -> Result<Vec<(Time, Replayed)>, FlightLogError> {
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
    let lag_us = (lag_s * 1e6) as u64;
    Ok((0..t.len())
        .map(|i| {
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
            (Time::from_micros(t[i]), Replayed::Gps(f))
        })
        .collect())
}

fn baro(log: &Log, lag_s: f64) -> Result<Vec<(Time, Replayed)>, FlightLogError> {
    let t = log.sample_times_us("vehicle_air_data")?;
    let alt = log.column("vehicle_air_data", "baro_alt_meter")?;
    let lag_us = (lag_s * 1e6) as u64;
    Ok(t.into_iter()
        .zip(alt)
        .map(|(t, alt)| {
            let s = BaroSample {
                time: Time::from_micros(t.saturating_sub(lag_us)),
                pressure_pa: 0.0,
                altitude_m: alt,
                temperature_c: 0.0,
            };
            (Time::from_micros(t), Replayed::Baro(s))
        })
        .collect())
}

fn mag(log: &Log, lag_s: f64) -> Result<Vec<(Time, Replayed)>, FlightLogError> {
    let t = log.sample_times_us("vehicle_magnetometer")?;
    let field = log.vec3("vehicle_magnetometer", "magnetometer_ga")?;
    let lag_us = (lag_s * 1e6) as u64;
    Ok(t.into_iter()
        .zip(field)
        .map(|(t, field)| {
            let s = MagSample { time: Time::from_micros(t.saturating_sub(lag_us)), field_gauss: field };
            (Time::from_micros(t), Replayed::Mag(s))
        })
        .collect())
}

/// EKF2's estimate: each `vehicle_attitude` with the `vehicle_local_position` nearest it.
fn ekf2(log: &Log) -> Result<Reference, FlightLogError> {
    let att_t = log.sample_times_us("vehicle_attitude")?;
    let att_q = log.vec4("vehicle_attitude", "q")?;
    let local = if log.has("vehicle_local_position") {
        let topic = "vehicle_local_position";
        let t = log.sample_times_us(topic)?;
        let [x, y, z, xy_valid, z_valid, xy_global, ref_lat, ref_lon, ref_alt] =
            ["x", "y", "z", "xy_valid", "z_valid", "xy_global", "ref_lat", "ref_lon", "ref_alt"]
                .map(|field| log.column(topic, field));
        let (x, y, z, xy_valid, z_valid, xy_global) = (x?, y?, z?, xy_valid?, z_valid?, xy_global?);
        let (ref_lat, ref_lon, ref_alt) = (ref_lat?, ref_lon?, ref_alt?);
        let positions: Vec<(Time, ReferencePosition)> = (0..t.len())
            .map(|i| {
                // Without a global origin EKF2's horizontal position is its own dead reckoning,
                // not comparable with ours.
                let origin = (xy_global[i] > 0.5).then(|| Geodetic {
                    lat_deg: ref_lat[i],
                    lon_deg: ref_lon[i],
                    alt_m: ref_alt[i],
                });
                let position = ReferencePosition {
                    place: Place::Local { ned_m: [x[i], y[i], z[i]], origin },
                    horizontal_valid: xy_valid[i] > 0.5 && origin.is_some(),
                    vertical_valid: z_valid[i] > 0.5,
                };
                (Time::from_micros(t[i]), position)
            })
            .collect();
        Some(positions)
    } else {
        None
    };
    let samples = att_t
        .iter()
        .zip(&att_q)
        .map(|(&t, &q)| ReferenceSample {
            time: Time::from_micros(t),
            attitude: Some(q),
            position: local
                .as_deref()
                .and_then(|lp| nearest(lp, |(t, _)| *t, t, LOCAL_POSITION_GAP_US))
                .map(|(_, p)| *p),
        })
        .collect();
    Ok(Reference { label: "EKF2", samples, align_height: true })
}
