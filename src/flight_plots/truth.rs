//! The estimate against simulator ground truth, per NED axis: position and velocity.

use super::chart::{ESTIMATE, Figure, Panel, Shape, TRUTH, Trace};
use super::series::{FlightSeries, StatePoint};

const AXES: [&str; 3] = ["North", "East", "Down"];

/// Position and velocity figures, or none when the log has no ground truth.
pub(crate) fn figures(series: &FlightSeries) -> Vec<Figure> {
    let Some(truth) = &series.truth else { return Vec::new() };
    let position = |p: &StatePoint, axis: usize| p.position_ned_m[axis];
    let velocity = |p: &StatePoint, axis: usize| p.velocity_ned_m_s[axis];
    vec![
        Figure {
            file_name: "truth_position.png",
            title: "EKF position vs ground truth (NED frame)".to_owned(),
            panels: panels(series, truth, "position", "m", position),
        },
        Figure {
            file_name: "truth_velocity.png",
            title: "EKF velocity vs ground truth (NED frame)".to_owned(),
            panels: panels(series, truth, "velocity", "m/s", velocity),
        },
    ]
}

/// One panel per axis of `quantity` (read by `value`), truth and estimate.
fn panels(
    series: &FlightSeries,
    truth: &[StatePoint],
    quantity: &str,
    unit: &str,
    value: impl Fn(&StatePoint, usize) -> f64,
) -> Vec<Panel> {
    AXES.iter()
        .enumerate()
        .map(|(axis, name)| Panel {
            title: format!("{name} {quantity}"),
            y_label: format!("{} ({unit})", name.to_lowercase()),
            traces: vec![
                Trace {
                    label: "ground truth".to_owned(),
                    color: TRUTH,
                    shape: Shape::Line,
                    points: truth.iter().map(|t| (t.t_s, value(t, axis))).collect(),
                },
                Trace {
                    label: "EKF".to_owned(),
                    color: ESTIMATE,
                    shape: Shape::Line,
                    points: series.nav.iter().map(|n| (n.t_s, value(n, axis))).collect(),
                },
            ],
        })
        .collect()
}
