//! The obstacle avoider over time, as thesis Fig. 3.41–3.42 show it: the near-pixel shares of
//! the five main regions of the depth grid it was fed, and the three velocity corrections it
//! asked for (`avoidance.png`).

use kestrel_proto::messages::AvoidanceCommand;
use plotters::style::RGBColor;

use super::PlotError;
use super::chart::{Figure, Panel, Shape, Trace};
use super::series::{FlightSeries, topic_of};
use crate::recorder::LogReader;

/// File name of the figure.
pub(crate) const FILE: &str = "avoidance.png";

/// The five regions the thesis plots, as `(name, row, column)` of
/// [`AvoidanceCommand::near_shares`], each with its colour.
const REGIONS: [(&str, usize, usize, RGBColor); 5] = [
    ("centre", 1, 1, RGBColor(0, 0, 0)),
    ("up", 0, 1, RGBColor(31, 119, 180)),
    ("down", 2, 1, RGBColor(140, 86, 75)),
    ("left", 1, 0, RGBColor(44, 160, 44)),
    ("right", 1, 2, RGBColor(214, 39, 40)),
];

/// The body axes of [`AvoidanceCommand::velocity_frd_m_s`], each with its colour.
const AXES: [(&str, RGBColor); 3] =
    [("forward", RGBColor(31, 119, 180)), ("right", RGBColor(214, 39, 40)), ("down", RGBColor(44, 160, 44))];

/// Every avoidance command of a flight, at seconds from the log's start.
pub(crate) struct AvoidanceLog {
    pub commands: Vec<(f64, AvoidanceCommand)>,
}

impl AvoidanceLog {
    /// The log's avoidance commands, or `None` when it has none (the avoider did not run).
    pub fn read(log: &LogReader, series: &FlightSeries) -> Result<Option<AvoidanceLog>, PlotError> {
        let Some(topic) = topic_of::<AvoidanceCommand>(log, "avoidance_command") else { return Ok(None) };
        let mut commands: Vec<(f64, AvoidanceCommand)> = log
            .read::<AvoidanceCommand>(&topic)?
            .into_iter()
            .map(|r| (series.clock.secs(r.publish_time), r.message))
            .collect();
        commands.sort_by(|a, b| a.0.total_cmp(&b.0));
        Ok((!commands.is_empty()).then_some(AvoidanceLog { commands }))
    }

    /// Region shares in one panel, then one panel per velocity axis.
    pub fn figure(&self) -> Figure {
        let shares = Panel {
            title: "Near-pixel share of the depth grid's main regions (the avoider's inputs)".to_owned(),
            y_label: "share of near pixels (0..1)".to_owned(),
            traces: REGIONS
                .iter()
                .map(|&(name, row, column, color)| Trace {
                    label: name.to_owned(),
                    color,
                    shape: Shape::Steps,
                    points: self
                        .commands
                        .iter()
                        .map(|(t, c)| (*t, f64::from(c.near_shares[row][column])))
                        .collect(),
                })
                .collect(),
        };
        let velocity = AXES.iter().enumerate().map(|(axis, &(name, color))| Panel {
            title: format!("Velocity correction, {name} (body FRD, low-pass filtered)"),
            y_label: format!("{name} (m/s)"),
            traces: vec![Trace {
                label: format!("{name} correction"),
                color,
                shape: Shape::Line,
                points: self.commands.iter().map(|(t, c)| (*t, c.velocity_frd_m_s[axis])).collect(),
            }],
        });
        Figure {
            file_name: FILE,
            title: "Obstacle avoider: region shares in, velocity corrections out".to_owned(),
            panels: [shares].into_iter().chain(velocity).collect(),
        }
    }
}
