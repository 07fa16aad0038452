//! Height and climb rate, barometer against the estimate (thesis Fig. 3.14, 3.15, 4.3, 4.4).

use super::chart::{ESTIMATE, Figure, MEASURED, Panel, Shape, Trace};
use super::series::FlightSeries;

/// The height and climb-rate figures.
pub(crate) fn figures(series: &FlightSeries) -> Vec<Figure> {
    let height = Figure {
        file_name: "height.png",
        title: "Barometer height vs EKF height".to_owned(),
        panels: vec![Panel {
            title: format!(
                "Height above the origin (barometer offset by {:.2} m to the estimate's mean)",
                series.baro_offset_m
            ),
            y_label: "height (m)".to_owned(),
            traces: vec![
                Trace {
                    label: "barometer (as received)".to_owned(),
                    color: MEASURED,
                    shape: Shape::Line,
                    points: series.baro_height_m.iter().map(|b| (b.arrived_s, b.value)).collect(),
                },
                Trace {
                    label: "EKF".to_owned(),
                    color: ESTIMATE,
                    shape: Shape::Line,
                    points: series.nav.iter().map(|n| (n.t_s, -n.position_ned_m[2])).collect(),
                },
            ],
        }],
    };
    let climb = Figure {
        file_name: "climb_rate.png",
        title: "Barometer climb rate vs EKF climb rate".to_owned(),
        panels: vec![Panel {
            title: "Climb rate (up positive; barometer: slope of its last 5 heights)".to_owned(),
            y_label: "climb rate (m/s)".to_owned(),
            traces: vec![
                Trace {
                    label: "barometer (as received)".to_owned(),
                    color: MEASURED,
                    shape: Shape::Line,
                    points: series.baro_climb_m_s.iter().map(|b| (b.arrived_s, b.value)).collect(),
                },
                Trace {
                    label: "EKF".to_owned(),
                    color: ESTIMATE,
                    shape: Shape::Line,
                    points: series.nav.iter().map(|n| (n.t_s, -n.velocity_ned_m_s[2])).collect(),
                },
            ],
        }],
    };
    vec![height, climb]
}
