//! Drawing: one PNG figure of stacked time-series panels, each with a legend, in the house
//! style (white background, DejaVu Sans, sensors in red or orange, the estimate in blue, the
//! truth in green).

use std::fmt::Display;
use std::path::Path;

use plotters::prelude::*;

use super::font::FAMILY;
use super::{PLOT_SIZE_PX, PlotError, PlotFile};

/// A measurement as the vehicle received it.
pub(crate) const MEASURED: RGBColor = RGBColor(214, 39, 40);
/// A measurement placed at its time of validity.
pub(crate) const MEASURED_AT_VALIDITY: RGBColor = RGBColor(255, 127, 14);
/// The estimator's output.
pub(crate) const ESTIMATE: RGBColor = RGBColor(31, 119, 180);
/// Simulator ground truth.
pub(crate) const TRUTH: RGBColor = RGBColor(44, 160, 44);

/// Most points a trace is drawn with: more than the figure has pixel columns, few enough to
/// draw a long flight quickly.
const MAX_POINTS: usize = 4000;

/// Share of a panel's value span left free above the data, so the legend (upper right) does
/// not hide it.
const LEGEND_HEADROOM: f64 = 0.4;

/// How a trace joins its samples.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Shape {
    /// Straight lines between samples.
    Line,
    /// Each value held until the next sample, as a low-rate sensor looks to the estimator.
    Steps,
}

/// One labelled line of (time s, value) points.
pub(crate) struct Trace {
    pub label: String,
    pub color: RGBColor,
    pub shape: Shape,
    pub points: Vec<(f64, f64)>,
}

/// One chart of a figure.
pub(crate) struct Panel {
    pub title: String,
    /// The value axis' name with its unit.
    pub y_label: String,
    pub traces: Vec<Trace>,
}

/// A figure: panels stacked top to bottom in one PNG.
pub(crate) struct Figure {
    /// File name inside the report directory.
    pub file_name: &'static str,
    pub title: String,
    pub panels: Vec<Panel>,
}

/// Draws `figure` into `out_dir` as a [`PLOT_SIZE_PX`] PNG.
pub(crate) fn draw(out_dir: &Path, figure: &Figure) -> Result<PlotFile, PlotError> {
    let path = out_dir.join(figure.file_name);
    let fail = |e: &dyn Display| PlotError::Draw { path: path.clone(), message: e.to_string() };
    let root = BitMapBackend::new(&path, PLOT_SIZE_PX).into_drawing_area();
    root.fill(&WHITE).map_err(|e| fail(&e))?;
    let body = root.titled(&figure.title, (FAMILY, 30)).map_err(|e| fail(&e))?;
    let rows = figure.panels.len().max(1);
    for (area, panel) in body.split_evenly((rows, 1)).iter().zip(&figure.panels) {
        draw_panel(area, panel).map_err(|e| fail(&e))?;
    }
    root.present().map_err(|e| fail(&e))?;
    Ok(PlotFile {
        file: path.clone(),
        title: figure.title.clone(),
        width_px: PLOT_SIZE_PX.0,
        height_px: PLOT_SIZE_PX.1,
    })
}

type AreaError = DrawingAreaErrorKind<<BitMapBackend<'static> as DrawingBackend>::ErrorType>;

fn draw_panel(
    area: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    panel: &Panel,
) -> Result<(), AreaError> {
    let traces: Vec<(&Trace, Vec<(f64, f64)>)> = panel.traces.iter().map(|t| (t, drawn_points(t))).collect();
    let (x, y) = ranges(traces.iter().flat_map(|(_, p)| p));
    let (x_decimals, y_decimals) = (decimals(x.1 - x.0), decimals(y.1 - y.0));
    let x_label = |v: &f64| tick_label(*v, x_decimals);
    let y_label = |v: &f64| tick_label(*v, y_decimals);
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, (FAMILY, 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(80)
        .build_cartesian_2d(x.0..x.1, y.0..y.1)?;
    chart
        .configure_mesh()
        .x_desc("time (s)")
        .y_desc(&panel.y_label)
        .x_label_formatter(&x_label)
        .y_label_formatter(&y_label)
        .label_style((FAMILY, 16))
        .axis_desc_style((FAMILY, 18))
        .light_line_style(RGBColor(236, 236, 236))
        .bold_line_style(RGBColor(210, 210, 210))
        .draw()?;
    for (trace, points) in traces {
        let style = trace.color.stroke_width(2);
        chart
            .draw_series(LineSeries::new(points, style))?
            .label(trace.label.as_str())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 24, y)], style));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font((FAMILY, 16))
        .draw()?;
    Ok(())
}

/// A trace's finite points, thinned to [`MAX_POINTS`] and shaped.
fn drawn_points(trace: &Trace) -> Vec<(f64, f64)> {
    let finite: Vec<(f64, f64)> =
        trace.points.iter().copied().filter(|(t, v)| t.is_finite() && v.is_finite()).collect();
    let thinned = thin(finite);
    match trace.shape {
        Shape::Line => thinned,
        Shape::Steps => {
            let mut steps = Vec::with_capacity(thinned.len() * 2);
            for (i, &(t, v)) in thinned.iter().enumerate() {
                if let Some(&(_, previous)) = i.checked_sub(1).and_then(|j| thinned.get(j)) {
                    steps.push((t, previous));
                }
                steps.push((t, v));
            }
            steps
        }
    }
}

/// Keeps the lowest and highest point of each run of samples, so a long noisy trace keeps its
/// envelope in at most [`MAX_POINTS`] points.
fn thin(points: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    if points.len() <= MAX_POINTS {
        return points;
    }
    let run = points.len().div_ceil(MAX_POINTS / 2);
    let mut out = Vec::with_capacity(MAX_POINTS);
    for chunk in points.chunks(run) {
        let lowest = chunk.iter().enumerate().min_by(|a, b| a.1.1.total_cmp(&b.1.1));
        let highest = chunk.iter().enumerate().max_by(|a, b| a.1.1.total_cmp(&b.1.1));
        if let (Some((i, &low)), Some((j, &high))) = (lowest, highest) {
            out.extend(if i <= j { [low, high] } else { [high, low] });
        }
    }
    out
}

/// Decimals that tell apart the ticks of an axis `span` wide (about ten ticks).
fn decimals(span: f64) -> usize {
    (-(span / 10.0).log10()).ceil().clamp(0.0, 6.0) as usize
}

/// `value` with `decimals`, without the "-0.0" of a value that rounds to zero.
fn tick_label(value: f64, decimals: usize) -> String {
    let text = format!("{value:.decimals$}");
    if text.chars().all(|c| matches!(c, '-' | '0' | '.')) { text.replace('-', "") } else { text }
}

/// Axis ranges covering `points`: time edge to edge; values with a margin below and headroom
/// above for the legend. A flat or empty series gets a unit-wide range.
fn ranges<'a>(points: impl Iterator<Item = &'a (f64, f64)>) -> ((f64, f64), (f64, f64)) {
    let (mut x, mut y) = ((f64::INFINITY, f64::NEG_INFINITY), (f64::INFINITY, f64::NEG_INFINITY));
    for &(t, v) in points {
        x = (x.0.min(t), x.1.max(t));
        y = (y.0.min(v), y.1.max(v));
    }
    let widen = |(lo, hi): (f64, f64), below: f64, above: f64| {
        if !(lo.is_finite() && hi.is_finite()) {
            (0.0, 1.0)
        } else if hi - lo < 1e-9 {
            (lo - 0.5, hi + 0.5)
        } else {
            (lo - below * (hi - lo), hi + above * (hi - lo))
        }
    };
    (widen(x, 0.0, 0.0), widen(y, 0.05, LEGEND_HEADROOM))
}
