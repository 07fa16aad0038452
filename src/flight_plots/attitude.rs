//! Attitude error against ground truth: roll, pitch and yaw of the estimate minus the truth's,
//! wrapped to ±180°. Euler angles here are for display only (`kestrel_proto::attitude`).

use kestrel_proto::attitude::angle_difference_rad;

use super::chart::{ESTIMATE, Figure, Panel, Shape, Trace};
use super::series::FlightSeries;

/// The attitude-error figure, or none when the log has no ground truth.
pub(crate) fn figures(series: &FlightSeries) -> Vec<Figure> {
    if series.truth.is_none() {
        return Vec::new();
    }
    let errors: Vec<(f64, [f64; 3])> = series
        .truth_pairs()
        .filter_map(|(truth, nav)| {
            let (estimate, truth_angles) = (nav.euler_rad?, truth.euler_rad?);
            Some((
                truth.t_s,
                [0, 1, 2].map(|i| angle_difference_rad(estimate[i], truth_angles[i]).to_degrees()),
            ))
        })
        .collect();
    let panel = |axis: usize, name: &str| Panel {
        title: format!("{name} error (EKF − truth)"),
        y_label: format!("{} error (°)", name.to_lowercase()),
        traces: vec![Trace {
            label: format!("{} error", name.to_lowercase()),
            color: ESTIMATE,
            shape: Shape::Line,
            points: errors.iter().map(|&(t, e)| (t, e[axis])).collect(),
        }],
    };
    vec![Figure {
        file_name: "attitude_error.png",
        title: "EKF attitude error vs ground truth".to_owned(),
        panels: vec![panel(0, "Roll"), panel(1, "Pitch"), panel(2, "Yaw")],
    }]
}
