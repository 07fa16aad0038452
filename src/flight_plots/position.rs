//! Horizontal position, GPS against the estimate: north and east over the whole flight (thesis
//! Fig. 3.8, 3.10, 4.5, 4.6) and a zoom where the estimate leads the lagged GPS (Fig. 3.9,
//! 3.11, 4.7).

use super::chart::{ESTIMATE, Figure, MEASURED, MEASURED_AT_VALIDITY, Panel, Shape, Trace};
use super::series::FlightSeries;

/// Width of the zoom window (s): ten GPS fixes at 5 Hz.
const ZOOM_SPAN_S: f64 = 2.0;

/// Below this horizontal speed (m/s) the vehicle counts as still and the zoom sits mid-flight.
const STILL_SPEED_M_S: f64 = 0.2;

/// The north, east and zoom figures.
pub(crate) fn figures(series: &FlightSeries) -> Vec<Figure> {
    vec![
        whole_flight(series, 0, "position_north.png", "North"),
        whole_flight(series, 1, "position_east.png", "East"),
        zoom(series),
    ]
}

/// GPS as received against the estimate along NED axis `axis` (0 north, 1 east).
fn whole_flight(series: &FlightSeries, axis: usize, file_name: &'static str, name: &str) -> Figure {
    Figure {
        file_name,
        title: format!("GPS position vs EKF position, {name}"),
        panels: vec![Panel {
            title: format!("{name} of the origin (NED frame)"),
            y_label: format!("{} (m)", name.to_lowercase()),
            traces: vec![
                Trace {
                    label: "GPS (as received)".to_owned(),
                    color: MEASURED,
                    shape: Shape::Line,
                    points: series.gps.iter().map(|g| (g.arrived_s, g.value.position_ned_m[axis])).collect(),
                },
                Trace {
                    label: "EKF".to_owned(),
                    color: ESTIMATE,
                    shape: Shape::Line,
                    points: series.nav.iter().map(|n| (n.t_s, n.position_ned_m[axis])).collect(),
                },
            ],
        }],
    }
}

/// North and east over [`ZOOM_SPAN_S`] around the fastest horizontal motion: GPS held from
/// arrival, GPS held from its time of validity, and the estimate.
fn zoom(series: &FlightSeries) -> Figure {
    let (start, end) = zoom_window(series);
    let latency_ms = series.gps.iter().map(|g| g.arrived_s - g.measured_s).sum::<f64>()
        / series.gps.len().max(1) as f64
        * 1e3;
    let panel = |axis: usize, name: &str| Panel {
        title: format!("{name} (NED frame)"),
        y_label: format!("{} (m)", name.to_lowercase()),
        traces: vec![
            Trace {
                label: "GPS (as received)".to_owned(),
                color: MEASURED,
                shape: Shape::Steps,
                points: held(
                    series.gps.iter().map(|g| (g.arrived_s, g.value.position_ned_m[axis])),
                    start,
                    end,
                ),
            },
            Trace {
                label: format!("GPS at time of validity ({latency_ms:.0} ms earlier)"),
                color: MEASURED_AT_VALIDITY,
                shape: Shape::Steps,
                points: held(
                    series.gps.iter().map(|g| (g.measured_s, g.value.position_ned_m[axis])),
                    start,
                    end,
                ),
            },
            Trace {
                label: "EKF".to_owned(),
                color: ESTIMATE,
                shape: Shape::Line,
                points: series
                    .nav
                    .iter()
                    .filter(|n| (start..=end).contains(&n.t_s))
                    .map(|n| (n.t_s, n.position_ned_m[axis]))
                    .collect(),
            },
        ],
    };
    Figure {
        file_name: "position_zoom.png",
        title: format!("Zoom: EKF leads the lagged GPS, t = {start:.1}–{end:.1} s"),
        panels: vec![panel(0, "North"), panel(1, "East")],
    }
}

/// The zoom window: centred on the fastest horizontal estimate, or mid-flight if the vehicle
/// never moved; kept inside the estimate's time span.
fn zoom_window(series: &FlightSeries) -> (f64, f64) {
    let (Some(first), Some(last)) = (series.nav.first(), series.nav.last()) else {
        return (0.0, ZOOM_SPAN_S);
    };
    let speed = |n: &super::series::StatePoint| n.velocity_ned_m_s[0].hypot(n.velocity_ned_m_s[1]);
    let fastest = series.nav.iter().max_by(|a, b| speed(a).total_cmp(&speed(b)));
    let centre = match fastest {
        Some(n) if speed(n) >= STILL_SPEED_M_S => n.t_s,
        _ => (first.t_s + last.t_s) / 2.0,
    };
    let start = (centre - ZOOM_SPAN_S / 2.0).min(last.t_s - ZOOM_SPAN_S).max(first.t_s);
    (start, start + ZOOM_SPAN_S)
}

/// The samples of a held (step) signal inside `start..=end`, starting with the value held at
/// `start`.
fn held(samples: impl Iterator<Item = (f64, f64)>, start: f64, end: f64) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::new();
    let mut before = None;
    for (t, v) in samples {
        if t < start {
            before = Some(v);
        } else if t <= end {
            out.push((t, v));
        }
    }
    if let Some(v) = before {
        out.insert(0, (start, v));
    }
    if let Some(&(_, v)) = out.last() {
        out.push((end, v));
    }
    out
}
