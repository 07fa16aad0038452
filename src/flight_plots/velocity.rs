//! NED velocity, GPS against the estimate (thesis Fig. 3.12, 3.13, 4.8, 4.9, with down added).

use super::chart::{ESTIMATE, Figure, MEASURED, Panel, Shape, Trace};
use super::series::FlightSeries;

/// North, east and down velocity, one panel each.
pub(crate) fn figure(series: &FlightSeries) -> Figure {
    let panel = |axis: usize, name: &str| Panel {
        title: format!("{name} velocity"),
        y_label: format!("v {} (m/s)", name.to_lowercase()),
        traces: vec![
            Trace {
                label: "GPS (as received)".to_owned(),
                color: MEASURED,
                shape: Shape::Line,
                points: series.gps.iter().map(|g| (g.arrived_s, g.value.velocity_ned_m_s[axis])).collect(),
            },
            Trace {
                label: "EKF".to_owned(),
                color: ESTIMATE,
                shape: Shape::Line,
                points: series.nav.iter().map(|n| (n.t_s, n.velocity_ned_m_s[axis])).collect(),
            },
        ],
    };
    Figure {
        file_name: "velocity_ned.png",
        title: "GPS velocity vs EKF velocity (NED frame)".to_owned(),
        panels: vec![panel(0, "North"), panel(1, "East"), panel(2, "Down")],
    }
}
