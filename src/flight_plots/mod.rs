//! `kestrel report`: PNG plots and a summary of errors from a recorded flight, in the style of
//! the thesis's Fig. 3.8–3.15 and 4.3–4.9.
//!
//! [`write_report`] reads a flight log ([`crate::recorder::LogReader`]), puts the estimate,
//! the sensors and (in simulation) the ground truth into the estimator's local NED frame
//! ([`series`]), draws one PNG per figure family and writes `summary.json`:
//!
//! | file | shows |
//! |---|---|
//! | `position_north.png`, `position_east.png` | GPS vs EKF position (Fig. 3.8, 3.10, 4.5, 4.6) |
//! | `position_zoom.png` | two seconds where the EKF leads the lagged GPS (Fig. 3.9, 3.11, 4.7) |
//! | `velocity_ned.png` | GPS vs EKF velocity, north, east, down (Fig. 3.12, 3.13, 4.8, 4.9) |
//! | `height.png`, `climb_rate.png` | barometer vs EKF (Fig. 3.14, 3.15, 4.3, 4.4) |
//! | `truth_position.png`, `truth_velocity.png` | EKF vs ground truth per axis (simulation only) |
//! | `attitude_error.png` | roll, pitch, yaw error vs ground truth (simulation only) |
//! | `path_top.png` | flown and commanded path over the obstacle map, one scale east and north, collisions marked (Fig. 3.41–3.42; logs with an `obstacle_map`) |
//! | `path_side.png` | height along the distance flown, obstacles beside the path as bars (logs with an `obstacle_map`) |
//! | `avoidance.png` | the avoider's region shares in and velocity corrections out (Fig. 3.41–3.42; logs with `avoidance_command`) |
//!
//! Text is drawn with an embedded DejaVu Sans ([`font`]), so plots look the same on a headless
//! board without fonts.

mod attitude;
mod avoidance;
mod chart;
mod error;
mod flown_path;
mod font;
mod footprint;
mod height;
mod map_view;
mod path_map;
mod position;
mod series;
mod summary;
mod truth;
mod velocity;

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::recorder::LogReader;
use avoidance::AvoidanceLog;
use flown_path::FlownPath;
use series::FlightSeries;

pub use error::PlotError;
pub use summary::{AvoidanceActivity, BaroErrors, GpsErrors, ObstacleEncounters, ReportSummary, TruthErrors};

/// Width and height of every plot (pixels).
pub const PLOT_SIZE_PX: (u32, u32) = (1280, 960);

/// Name of the summary written beside the plots.
pub const SUMMARY_FILE: &str = "summary.json";

/// A PNG the report wrote.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlotFile {
    /// Path of the PNG.
    pub file: PathBuf,
    /// The figure's title.
    pub title: String,
    pub width_px: u32,
    pub height_px: u32,
}

/// Reads the flight log `log`, writes the plots and `summary.json` into `out_dir` (created if
/// missing) and returns the summary.
///
/// The log needs the estimate (`kestrel.NavState`, with an origin), GPS fixes and barometer
/// samples; ground truth is optional and adds the truth and attitude-error figures; an
/// obstacle map (with obstacles) adds the path figures and avoidance commands the avoider's.
pub fn write_report(log: &Path, out_dir: &Path) -> Result<ReportSummary, PlotError> {
    let reader = LogReader::open(log)?;
    let series = FlightSeries::read(&reader)?;
    let path = FlownPath::read(&reader, &series)?;
    let avoidance = AvoidanceLog::read(&reader, &series)?;
    std::fs::create_dir_all(out_dir)
        .map_err(|source| PlotError::CreateDir { path: out_dir.to_owned(), source })?;
    font::register()?;
    let figures = position::figures(&series)
        .into_iter()
        .chain([velocity::figure(&series)])
        .chain(height::figures(&series))
        .chain(truth::figures(&series))
        .chain(attitude::figures(&series));
    let mut plots = figures.map(|figure| chart::draw(out_dir, &figure)).collect::<Result<Vec<_>, _>>()?;
    if let Some(path) = &path {
        plots.extend(path_map::draw(out_dir, path)?);
    }
    if let Some(avoidance) = &avoidance {
        plots.push(chart::draw(out_dir, &avoidance.figure())?);
    }
    let damage = reader.damage().cloned();
    let summary = ReportSummary::new(log, &series, path.as_ref(), avoidance.as_ref(), plots, damage);
    summary.write(&out_dir.join(SUMMARY_FILE))?;
    Ok(summary)
}
