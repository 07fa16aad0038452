//! The report's numbers: root-mean-square differences between the estimate and each sensor
//! (GPS, barometer) at the sensor's measurement time, and between the estimate and ground truth
//! when the log has it. Written as `summary.json` and printed by `kestrel report`.

use std::fmt;
use std::path::{Path, PathBuf};

use kestrel_proto::attitude::angle_difference_rad;
use kestrel_proto::geo::Geodetic;
use serde::{Deserialize, Serialize};

use super::avoidance::AvoidanceLog;
use super::flown_path::FlownPath;
use super::series::FlightSeries;
use super::{PlotError, PlotFile};
use crate::recorder::LogDamage;

/// Everything `kestrel report` measured, and the plots it drew.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReportSummary {
    /// The flight log read.
    pub log: PathBuf,
    /// From the log's first message to its last (s).
    pub duration_s: f64,
    /// Origin of the NED frame every position is expressed in: the estimator's first origin.
    pub origin: Geodetic,
    /// Estimates (`NavState`, after the origin was set) in the log.
    pub estimates: u64,
    /// Mean time from a GPS fix's validity to its arrival (ms); `None` without 3-D fixes.
    pub gps_latency_ms: Option<f64>,
    /// The estimate against GPS; `None` if no fix fell inside the estimate's time span.
    pub vs_gps: Option<GpsErrors>,
    /// The estimate against the barometer; `None` if no sample fell inside it.
    pub vs_baro: Option<BaroErrors>,
    /// The estimate against ground truth; `None` if the log has none (a real flight).
    pub vs_truth: Option<TruthErrors>,
    /// The flight against the world's obstacles; `None` without an obstacle map with
    /// obstacles (a real flight, or an empty world).
    pub obstacles: Option<ObstacleEncounters>,
    /// The avoider's corrections; `None` when the log has no avoidance commands.
    pub avoidance: Option<AvoidanceActivity>,
    /// The PNG files written.
    pub plots: Vec<PlotFile>,
    /// How much of the log was lost, when it is truncated or damaged (the report covers what
    /// was readable); `None` for a whole log.
    pub log_damage: Option<LogDamage>,
}

/// How close the true path came to the world's obstacles.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ObstacleEncounters {
    /// Obstacles in the world's map.
    pub obstacles: u64,
    /// Collisions the simulator counted.
    pub collisions: u32,
    /// When each collision began (s from the log's start).
    pub collision_times_s: Vec<f64>,
    /// Smallest distance from the vehicle's centre to an obstacle surface (m).
    pub min_clearance_m: Option<f64>,
    /// Horizontal length of the true path (m).
    pub path_length_m: f64,
}

/// What the avoider asked for over the flight.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AvoidanceActivity {
    /// Avoidance commands in the log.
    pub commands: u64,
    /// Commands made without a fresh depth grid.
    pub stale: u64,
    /// Largest magnitude of the velocity correction along forward, right, down (m/s).
    pub max_abs_correction_frd_m_s: [f64; 3],
}

/// RMS of the estimate minus GPS, at each fix's time of validity.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GpsErrors {
    pub rms_north_m: f64,
    pub rms_east_m: f64,
    pub rms_horizontal_m: f64,
    /// Down position against GPS altitude (m).
    pub rms_down_m: f64,
    pub rms_velocity_north_m_s: f64,
    pub rms_velocity_east_m_s: f64,
    pub rms_velocity_down_m_s: f64,
    /// Fixes compared.
    pub samples: u64,
}

/// RMS of the estimate minus the barometer, at each sample's measurement time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BaroErrors {
    /// Height, after removing the mean offset (m).
    pub rms_height_m: f64,
    /// Climb rate against the slope of the last five barometric heights (m/s); `None` with fewer
    /// than five samples.
    pub rms_climb_rate_m_s: Option<f64>,
    /// Barometric height above the origin minus the estimated height, averaged over the flight
    /// (m); removed before comparing.
    pub offset_m: f64,
    /// Heights compared.
    pub samples: u64,
}

/// RMS of the estimate minus ground truth, at each truth sample's time; the same definitions
/// as the flight report's (`kestrel run --report`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TruthErrors {
    pub rms_north_m: f64,
    pub rms_east_m: f64,
    pub rms_horizontal_m: f64,
    pub rms_vertical_m: f64,
    /// Of the 3-D velocity error vector (m/s).
    pub rms_velocity_m_s: f64,
    /// Attitude errors, over the samples with a valid estimated attitude; `None` without any.
    pub rms_roll_deg: Option<f64>,
    pub rms_pitch_deg: Option<f64>,
    /// Roll and pitch errors pooled (deg).
    pub rms_roll_pitch_deg: Option<f64>,
    pub rms_yaw_deg: Option<f64>,
    /// Truth samples compared.
    pub samples: u64,
}

/// A running root-mean-square.
#[derive(Clone, Copy, Default)]
struct Rms {
    sum_sq: f64,
    count: u64,
}

impl Rms {
    fn add(&mut self, error: f64) {
        self.sum_sq += error * error;
        self.count += 1;
    }

    fn value(self) -> Option<f64> {
        (self.count > 0).then(|| (self.sum_sq / self.count as f64).sqrt())
    }

    /// The RMS of the vector whose components `parts` accumulated.
    fn norm(parts: &[Rms]) -> Option<f64> {
        let count = parts.first()?.count;
        (count > 0).then(|| (parts.iter().map(|p| p.sum_sq).sum::<f64>() / count as f64).sqrt())
    }
}

impl ReportSummary {
    /// Measures `series` (read from `log`) and lists `plots`.
    pub(crate) fn new(
        log: &Path,
        series: &FlightSeries,
        path: Option<&FlownPath>,
        avoidance: Option<&AvoidanceLog>,
        plots: Vec<PlotFile>,
        log_damage: Option<LogDamage>,
    ) -> ReportSummary {
        let latencies: Vec<f64> = series.gps.iter().map(|g| g.arrived_s - g.measured_s).collect();
        ReportSummary {
            log: log.to_owned(),
            duration_s: series.duration_s,
            origin: series.origin,
            estimates: series.nav.len() as u64,
            gps_latency_ms: (!latencies.is_empty())
                .then(|| latencies.iter().sum::<f64>() / latencies.len() as f64 * 1e3),
            vs_gps: gps_errors(series),
            vs_baro: baro_errors(series),
            vs_truth: truth_errors(series),
            obstacles: path.map(encounters),
            avoidance: avoidance.map(activity),
            plots,
            log_damage,
        }
    }

    /// Writes the summary as pretty JSON to `path`.
    pub(crate) fn write(&self, path: &Path) -> Result<(), PlotError> {
        let json = serde_json::to_string_pretty(self).map_err(std::io::Error::other);
        json.and_then(|json| std::fs::write(path, json + "\n"))
            .map_err(|source| PlotError::WriteSummary { path: path.to_owned(), source })
    }
}

fn encounters(path: &FlownPath) -> ObstacleEncounters {
    ObstacleEncounters {
        obstacles: path.map.obstacles.len() as u64,
        collisions: path.collision_count,
        collision_times_s: path.collisions.iter().map(|p| p.t_s).collect(),
        min_clearance_m: path.min_clearance_m,
        path_length_m: path.along_track_m().last().copied().unwrap_or(0.0),
    }
}

fn activity(avoidance: &AvoidanceLog) -> AvoidanceActivity {
    let mut max = [0.0f64; 3];
    for (_, command) in &avoidance.commands {
        for (m, v) in max.iter_mut().zip(command.velocity_frd_m_s) {
            *m = m.max(v.abs());
        }
    }
    AvoidanceActivity {
        commands: avoidance.commands.len() as u64,
        stale: avoidance.commands.iter().filter(|(_, c)| c.health.stale).count() as u64,
        max_abs_correction_frd_m_s: max,
    }
}

fn gps_errors(series: &FlightSeries) -> Option<GpsErrors> {
    let (mut position, mut velocity) = ([Rms::default(); 3], [Rms::default(); 3]);
    for (fix, nav) in series.gps_pairs() {
        for axis in 0..3 {
            position[axis].add(nav.position_ned_m[axis] - fix.value.position_ned_m[axis]);
            velocity[axis].add(nav.velocity_ned_m_s[axis] - fix.value.velocity_ned_m_s[axis]);
        }
    }
    Some(GpsErrors {
        rms_north_m: position[0].value()?,
        rms_east_m: position[1].value()?,
        rms_horizontal_m: Rms::norm(&position[..2])?,
        rms_down_m: position[2].value()?,
        rms_velocity_north_m_s: velocity[0].value()?,
        rms_velocity_east_m_s: velocity[1].value()?,
        rms_velocity_down_m_s: velocity[2].value()?,
        samples: position[0].count,
    })
}

fn baro_errors(series: &FlightSeries) -> Option<BaroErrors> {
    let (mut height, mut climb) = (Rms::default(), Rms::default());
    for (sample, nav) in series.baro_pairs(&series.baro_height_m) {
        height.add(-nav.position_ned_m[2] - sample.value);
    }
    for (sample, nav) in series.baro_pairs(&series.baro_climb_m_s) {
        climb.add(-nav.velocity_ned_m_s[2] - sample.value);
    }
    Some(BaroErrors {
        rms_height_m: height.value()?,
        rms_climb_rate_m_s: climb.value(),
        offset_m: series.baro_offset_m,
        samples: height.count,
    })
}

fn truth_errors(series: &FlightSeries) -> Option<TruthErrors> {
    series.truth.as_ref()?;
    let (mut position, mut velocity, mut attitude) =
        ([Rms::default(); 3], [Rms::default(); 3], [Rms::default(); 3]);
    for (truth, nav) in series.truth_pairs() {
        for axis in 0..3 {
            position[axis].add(nav.position_ned_m[axis] - truth.position_ned_m[axis]);
            velocity[axis].add(nav.velocity_ned_m_s[axis] - truth.velocity_ned_m_s[axis]);
        }
        if let (Some(estimate), Some(true_angles)) = (nav.euler_rad, truth.euler_rad) {
            for axis in 0..3 {
                attitude[axis].add(angle_difference_rad(estimate[axis], true_angles[axis]));
            }
        }
    }
    let degrees = |rms: Option<f64>| rms.map(f64::to_degrees);
    Some(TruthErrors {
        rms_north_m: position[0].value()?,
        rms_east_m: position[1].value()?,
        rms_horizontal_m: Rms::norm(&position[..2])?,
        rms_vertical_m: position[2].value()?,
        rms_velocity_m_s: Rms::norm(&velocity)?,
        rms_roll_deg: degrees(attitude[0].value()),
        rms_pitch_deg: degrees(attitude[1].value()),
        rms_roll_pitch_deg: degrees(Rms::norm(&attitude[..2]).map(|v| v / 2f64.sqrt())),
        rms_yaw_deg: degrees(attitude[2].value()),
        samples: position[0].count,
    })
}

impl fmt::Display for ReportSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let o = &self.origin;
        writeln!(
            f,
            "{}: {:.1} s, {} estimates; origin {:.6}°, {:.6}°, {:.1} m",
            self.log.display(),
            self.duration_s,
            self.estimates,
            o.lat_deg,
            o.lon_deg,
            o.alt_m
        )?;
        if let Some(damage) = &self.log_damage {
            writeln!(f, "  the log is damaged or cut short, this report covers what was readable: {damage}")?;
        }
        if let Some(g) = &self.vs_gps {
            writeln!(
                f,
                "  vs GPS ({} fixes, {} latency): position RMS horizontal {:.3} m (north {:.3}, east {:.3}), down {:.3} m; velocity RMS north {:.3}, east {:.3}, down {:.3} m/s",
                g.samples,
                optional(self.gps_latency_ms, "ms", 0),
                g.rms_horizontal_m,
                g.rms_north_m,
                g.rms_east_m,
                g.rms_down_m,
                g.rms_velocity_north_m_s,
                g.rms_velocity_east_m_s,
                g.rms_velocity_down_m_s
            )?;
        }
        if let Some(b) = &self.vs_baro {
            writeln!(
                f,
                "  vs barometer ({} samples, offset {:.2} m removed): height RMS {:.3} m, climb rate RMS {}",
                b.samples,
                b.offset_m,
                b.rms_height_m,
                optional(b.rms_climb_rate_m_s, "m/s", 3)
            )?;
        }
        if let Some(t) = &self.vs_truth {
            writeln!(
                f,
                "  vs ground truth ({} samples): RMS horizontal {:.3} m, vertical {:.3} m, velocity {:.3} m/s, roll/pitch {}, yaw {}",
                t.samples,
                t.rms_horizontal_m,
                t.rms_vertical_m,
                t.rms_velocity_m_s,
                optional(t.rms_roll_pitch_deg, "°", 2),
                optional(t.rms_yaw_deg, "°", 2)
            )?;
        }
        if let Some(o) = &self.obstacles {
            writeln!(
                f,
                "  obstacles ({}): {} collision(s), min clearance {}, path {:.1} m",
                o.obstacles,
                o.collisions,
                optional(o.min_clearance_m, "m", 2),
                o.path_length_m
            )?;
        }
        if let Some(a) = &self.avoidance {
            let [forward, right, down] = a.max_abs_correction_frd_m_s;
            writeln!(
                f,
                "  avoider ({} commands, {} stale): largest correction forward {forward:.2}, right {right:.2}, down {down:.2} m/s",
                a.commands, a.stale
            )?;
        }
        let names: Vec<String> = self
            .plots
            .iter()
            .filter_map(|p| p.file.file_name())
            .map(|n| n.to_string_lossy().into_owned())
            .collect();
        write!(f, "  {} plots: {}", names.len(), names.join(", "))
    }
}

/// `value` with its unit and `decimals`, or "n/a".
fn optional(value: Option<f64>, unit: &str, decimals: usize) -> String {
    value.map_or_else(|| "n/a".to_owned(), |v| format!("{v:.decimals$} {unit}"))
}
