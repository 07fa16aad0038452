//! The flown path over the obstacle map (after thesis Fig. 3.41–3.42):
//! `path_top.png`, east against north at one scale with every obstacle to scale, and
//! `path_side.png`, height against the distance flown with the obstacles beside the path.
//! Both mark where the vehicle collided.

use std::fmt::Display;
use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use super::chart::{MEASURED, TRUTH};
use super::flown_path::{FlownPath, PathPoint};
use super::font::FAMILY;
use super::footprint::{self, Kind};
use super::map_view::MapView;
use super::{PLOT_SIZE_PX, PlotError, PlotFile};

/// File names of the two figures.
pub(crate) const TOP_FILE: &str = "path_top.png";
pub(crate) const SIDE_FILE: &str = "path_side.png";

/// The commanded path.
const SETPOINT: RGBColor = RGBColor(148, 103, 189);
/// Home, the NED origin.
const HOME: RGBColor = BLACK;

/// The side view shows obstacles whose outline the path passed within this distance of,
/// horizontally (m): close enough that the vehicle had to go over or around them.
const SIDE_CORRIDOR_M: f64 = 2.0;

/// Thinnest a wall is drawn (pixels), so a 0.3 m wall stays visible on a 100 m map.
const MIN_WALL_PX: u32 = 3;

/// Share of the height span left above the side view's content for the legend.
const SIDE_HEADROOM: f64 = 0.35;

/// The fill colour of an obstacle kind, and its legend label.
pub(crate) fn style(kind: Kind) -> (RGBColor, &'static str) {
    match kind {
        Kind::Tree => (RGBColor(140, 100, 60), "tree (cylinder)"),
        Kind::Box => (RGBColor(127, 127, 127), "box"),
        Kind::TexturedWall => (RGBColor(70, 70, 70), "wall, textured"),
        Kind::PlainWall => (RGBColor(230, 170, 30), "wall, plain (textureless)"),
    }
}

const KINDS: [Kind; 4] = [Kind::Tree, Kind::Box, Kind::TexturedWall, Kind::PlainWall];

/// Draws both figures into `out_dir`.
pub(crate) fn draw(out_dir: &Path, path: &FlownPath) -> Result<Vec<PlotFile>, PlotError> {
    Ok(vec![draw_top(out_dir, path)?.0, draw_side(out_dir, path)?])
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;
type AreaError = DrawingAreaErrorKind<<BitMapBackend<'static> as DrawingBackend>::ErrorType>;

/// A figure's PNG: the white image with its title, drawn into by `body`.
fn figure(
    out_dir: &Path,
    file_name: &str,
    title: &str,
    body: impl FnOnce(&Area<'_>) -> Result<(), AreaError>,
) -> Result<PlotFile, PlotError> {
    let file = out_dir.join(file_name);
    let fail = |e: &dyn Display| PlotError::Draw { path: file.clone(), message: e.to_string() };
    let root = BitMapBackend::new(&file, PLOT_SIZE_PX).into_drawing_area();
    root.fill(&WHITE).map_err(|e| fail(&e))?;
    let area = root.titled(title, (FAMILY, 30)).map_err(|e| fail(&e))?;
    body(&area).map_err(|e| fail(&e))?;
    root.present().map_err(|e| fail(&e))?;
    Ok(PlotFile {
        file: PathBuf::from(&file),
        title: title.to_owned(),
        width_px: PLOT_SIZE_PX.0,
        height_px: PLOT_SIZE_PX.1,
    })
}

/// The same margins and label areas for the sizing pass and the drawing.
fn builder<'a, 'b>(area: &'a Area<'b>) -> ChartBuilder<'a, 'b, BitMapBackend<'b>> {
    let mut builder = ChartBuilder::on(area);
    builder.margin(16).x_label_area_size(50).y_label_area_size(70);
    builder
}

/// The top view, and the scale it was drawn at.
fn draw_top(out_dir: &Path, path: &FlownPath) -> Result<(PlotFile, MapView), PlotError> {
    let outlines: Vec<(Kind, Vec<(f64, f64)>)> =
        path.map.obstacles.iter().map(|o| (footprint::kind(o), footprint::outline_ne_m(o))).collect();
    let ne = |p: &PathPoint| (p.position_ned_m[0], p.position_ned_m[1]);
    let content = outlines
        .iter()
        .flat_map(|(_, o)| o.iter().copied())
        .chain(path.truth.iter().map(ne))
        .chain(path.setpoints.iter().map(ne))
        .chain([(0.0, 0.0)]);
    let mut view = None;
    let title = format!(
        "Flown path over the obstacle map (top view): {} collision{}, min clearance {}",
        path.collision_count,
        if path.collision_count == 1 { "" } else { "s" },
        path.min_clearance_m.map_or_else(|| "n/a".to_owned(), |c| format!("{c:.2} m"))
    );
    let plot = figure(out_dir, TOP_FILE, &title, |area| {
        let sizing = builder(area).build_cartesian_2d(0.0..1.0, 0.0..1.0)?;
        let (columns, rows) = sizing.plotting_area().get_pixel_range();
        let fitted = MapView::fit(content, columns, rows);
        let mut chart = builder(area)
            .build_cartesian_2d(fitted.east_m.0..fitted.east_m.1, fitted.north_m.0..fitted.north_m.1)?;
        chart
            .configure_mesh()
            .x_desc("east of home (m)")
            .y_desc("north of home (m)")
            .label_style((FAMILY, 16))
            .axis_desc_style((FAMILY, 18))
            .light_line_style(RGBColor(240, 240, 240))
            .bold_line_style(RGBColor(215, 215, 215))
            .draw()?;
        let wall_px = (0.5 / fitted.metres_per_px()).max(f64::from(MIN_WALL_PX)) as u32;
        for kind in KINDS {
            let (color, label) = style(kind);
            let shapes: Vec<&Vec<(f64, f64)>> =
                outlines.iter().filter(|(k, _)| *k == kind).map(|(_, o)| o).collect();
            if shapes.is_empty() {
                continue;
            }
            let en = |o: &Vec<(f64, f64)>| o.iter().map(|&(n, e)| (e, n)).collect::<Vec<_>>();
            chart
                .draw_series(shapes.iter().map(|o| Polygon::new(en(o), color.filled())))?
                .label(label)
                .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 20, y + 6)], color.filled()));
            if matches!(kind, Kind::TexturedWall | Kind::PlainWall) {
                // A thin wall drawn to scale may be under a pixel wide: trace its outline thick.
                let outline = |o: &Vec<(f64, f64)>| {
                    let mut points = en(o);
                    points.extend(points.first().copied());
                    PathElement::new(points, color.stroke_width(wall_px))
                };
                chart.draw_series(shapes.iter().map(|o| outline(o)))?;
            }
        }
        let en = |p: &PathPoint| (p.position_ned_m[1], p.position_ned_m[0]);
        if !path.setpoints.is_empty() {
            let style = SETPOINT.stroke_width(2);
            chart
                .draw_series(LineSeries::new(path.setpoints.iter().map(en), style))?
                .label("position setpoint")
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], style));
        }
        let style = TRUTH.stroke_width(3);
        chart
            .draw_series(LineSeries::new(path.truth.iter().map(en), style))?
            .label("flown (ground truth)")
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], style));
        chart
            .draw_series([TriangleMarker::new((0.0, 0.0), 8, HOME.filled())])?
            .label("home")
            .legend(|(x, y)| TriangleMarker::new((x + 10, y), 6, HOME.filled()));
        mark_collisions(&mut chart, path.collisions.iter().map(en))?;
        legend(&mut chart)?;
        view = Some(fitted);
        Ok(())
    })?;
    let view =
        view.ok_or_else(|| PlotError::Draw { path: plot.file.clone(), message: "no map drawn".to_owned() })?;
    Ok((plot, view))
}

/// The side view: height against the horizontal distance flown.
fn draw_side(out_dir: &Path, path: &FlownPath) -> Result<PlotFile, PlotError> {
    let along = path.along_track_m();
    let beside = path.obstacles_beside(&along, SIDE_CORRIDOR_M);
    let height = |p: &PathPoint| -p.position_ned_m[2];
    let flown: Vec<(f64, f64)> = path.truth.iter().zip(&along).map(|(p, &s)| (s, height(p))).collect();
    let commanded: Vec<(f64, f64)> =
        path.setpoints.iter().map(|p| (path.along_track_at(&along, p.t_s), height(p))).collect();
    let collisions: Vec<(f64, f64)> =
        path.collisions.iter().map(|p| (path.along_track_at(&along, p.t_s), height(p))).collect();
    let length = along.last().copied().unwrap_or(0.0).max(1.0);
    let top = flown
        .iter()
        .chain(&commanded)
        .map(|&(_, h)| h)
        .chain(beside.iter().map(|(o, _, _)| footprint::heights_m(o).1))
        .fold(1.0, f64::max);
    let bottom = flown.iter().map(|&(_, h)| h).fold(0.0, f64::min);
    let title = format!(
        "Flown path, side view: height along the {length:.0} m flown, obstacles within {SIDE_CORRIDOR_M:.0} m of the path"
    );
    figure(out_dir, SIDE_FILE, &title, |area| {
        let mut chart =
            builder(area).build_cartesian_2d(0.0..length, bottom - 0.5..top * (1.0 + SIDE_HEADROOM))?;
        chart
            .configure_mesh()
            .x_desc("horizontal distance flown (m)")
            .y_desc("height above home (m)")
            .label_style((FAMILY, 16))
            .axis_desc_style((FAMILY, 18))
            .light_line_style(RGBColor(240, 240, 240))
            .bold_line_style(RGBColor(215, 215, 215))
            .draw()?;
        for kind in KINDS {
            let (color, label) = style(kind);
            let bars: Vec<_> = beside
                .iter()
                .filter(|(o, _, _)| footprint::kind(o) == kind)
                .map(|(o, start, end)| {
                    let (low, high) = footprint::heights_m(o);
                    // A path that only grazed an obstacle still gets a bar one pixel-ish wide.
                    let end = end.max(start + length / 400.0);
                    Rectangle::new([(*start, low), (end, high)], color.mix(0.75).filled())
                })
                .collect();
            if !bars.is_empty() {
                chart
                    .draw_series(bars)?
                    .label(label)
                    .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 20, y + 6)], color.filled()));
            }
        }
        if !commanded.is_empty() {
            let style = SETPOINT.stroke_width(2);
            chart
                .draw_series(LineSeries::new(commanded, style))?
                .label("position setpoint")
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], style));
        }
        let style = TRUTH.stroke_width(3);
        chart
            .draw_series(LineSeries::new(flown, style))?
            .label("flown (ground truth)")
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], style));
        mark_collisions(&mut chart, collisions.into_iter())?;
        legend(&mut chart)
    })
}

type Chart<'a, 'b> = ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A red cross at each collision, with a legend entry when there is one.
fn mark_collisions(chart: &mut Chart<'_, '_>, at: impl Iterator<Item = (f64, f64)>) -> Result<(), AreaError> {
    let style = MEASURED.stroke_width(3);
    let crosses: Vec<_> = at.map(|p| Cross::new(p, 9, style)).collect();
    if !crosses.is_empty() {
        chart
            .draw_series(crosses)?
            .label("collision")
            .legend(move |(x, y)| Cross::new((x + 10, y), 6, style));
    }
    Ok(())
}

fn legend<'a, 'b: 'a>(chart: &mut Chart<'a, 'b>) -> Result<(), AreaError> {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font((FAMILY, 16))
        .draw()
}

#[cfg(test)]
mod tests {
    use kestrel_proto::Time;
    use kestrel_proto::geo::Geodetic;
    use kestrel_proto::messages::{Obstacle, ObstacleMap};

    use super::*;
    use crate::flight_plots::font;

    /// A 40 m leg north past a tree 5 m east of it, with a wall across the far end.
    fn course() -> FlownPath {
        let point = |t_s: f64, n: f64| PathPoint { t_s, position_ned_m: [n, 0.0, -5.0] };
        FlownPath {
            map: ObstacleMap {
                time: Time::ZERO,
                home: Geodetic { lat_deg: 6.7971, lon_deg: 79.9017, alt_m: 20.0 },
                obstacles: vec![
                    Obstacle::Cylinder { base_ne_m: [20.0, 5.0], radius_m: 2.0, height_m: 8.0 },
                    Obstacle::Wall {
                        from_ne_m: [45.0, -8.0],
                        to_ne_m: [45.0, 8.0],
                        height_m: 4.0,
                        thickness_m: 0.3,
                        textured: false,
                    },
                ],
            },
            truth: (0..=40).map(|i| point(f64::from(i), f64::from(i))).collect(),
            setpoints: vec![point(0.0, 0.0), point(40.0, 40.0)],
            collisions: Vec::new(),
            collision_count: 0,
            min_clearance_m: Some(3.0),
        }
    }

    #[test]
    fn a_tree_lands_where_the_scale_puts_it_and_stays_round() {
        font::register().unwrap();
        let out = std::env::temp_dir().join(format!("kestrel-path-map-{}", std::process::id()));
        std::fs::create_dir_all(&out).unwrap();
        let (plot, view) = draw_top(&out, &course()).unwrap();
        let bytes = std::fs::read(&plot.file).unwrap();
        let _ = std::fs::remove_dir_all(&out);

        let mut reader = png::Decoder::new(bytes.as_slice()).read_info().unwrap();
        let mut pixels = vec![0; reader.output_buffer_size()];
        let frame = reader.next_frame(&mut pixels).unwrap();
        assert_eq!((frame.width, frame.height), PLOT_SIZE_PX);
        let channels = frame.color_type.samples();
        let (tree, _) = style(Kind::Tree);
        let (expected_column, expected_row) = view.pixel(20.0, 5.0);
        // Tree-coloured pixels near where the tree belongs (the legend's swatch is far away).
        let (mut columns, mut rows) = (Vec::new(), Vec::new());
        for (i, p) in pixels[..frame.buffer_size()].chunks(channels).enumerate() {
            let (column, row) = ((i % frame.width as usize) as f64, (i / frame.width as usize) as f64);
            let near = (column - expected_column).abs() < 60.0 && (row - expected_row).abs() < 60.0;
            if near && p[..3] == [tree.0, tree.1, tree.2] {
                columns.push(column);
                rows.push(row);
            }
        }
        assert!(!columns.is_empty(), "no tree drawn");
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let spread = |v: &[f64]| {
            v.iter().copied().fold(f64::NEG_INFINITY, f64::max)
                - v.iter().copied().fold(f64::INFINITY, f64::min)
        };
        assert!(
            (mean(&columns) - expected_column).abs() < 1.5,
            "tree centre column {} vs {expected_column}",
            mean(&columns)
        );
        assert!(
            (mean(&rows) - expected_row).abs() < 1.5,
            "tree centre row {} vs {expected_row}",
            mean(&rows)
        );
        // 4 m across, the same number of pixels both ways.
        let diameter_px = 4.0 / view.metres_per_px();
        assert!(
            (spread(&columns) - diameter_px).abs() < 3.0,
            "{} px wide, expected {diameter_px}",
            spread(&columns)
        );
        assert!(
            (spread(&rows) - diameter_px).abs() < 3.0,
            "{} px tall, expected {diameter_px}",
            spread(&rows)
        );
    }
}
