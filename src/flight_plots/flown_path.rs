//! What the map figures draw: the world's obstacles (the simulator's `obstacle_map`, published
//! once at start), the true flown path and the commanded path, all in the obstacle map's NED
//! frame around its home, where the obstacles are given; times in seconds from the log's start.

use kestrel_proto::geo::LocalFrame;
use kestrel_proto::messages::{GroundTruth, Obstacle, ObstacleMap, Setpoint, SetpointTarget};

use super::PlotError;
use super::footprint;
use super::series::{FlightSeries, topic_of};
use crate::recorder::LogReader;

/// A position at a time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct PathPoint {
    /// Seconds from the log's start.
    pub t_s: f64,
    /// North, east, down from the map's home (m).
    pub position_ned_m: [f64; 3],
}

/// The flight against the world's obstacles.
pub(crate) struct FlownPath {
    pub map: ObstacleMap,
    /// Simulator ground truth, in time order.
    pub truth: Vec<PathPoint>,
    /// Armed position setpoints holding all three axes, moved from the estimator's frame (where
    /// the commander flies) into the map's: where the vehicle was asked to be.
    pub setpoints: Vec<PathPoint>,
    /// Where the simulator's collision count rose.
    pub collisions: Vec<PathPoint>,
    /// Collisions over the flight (the last truth sample's count).
    pub collision_count: u32,
    /// Smallest distance from the vehicle's centre to any obstacle surface (m).
    pub min_clearance_m: Option<f64>,
}

impl FlownPath {
    /// The path over the map, or `None` when the log has no obstacle map, the map is empty (an
    /// empty world or a real flight), or there is no ground truth to draw.
    pub fn read(log: &LogReader, series: &FlightSeries) -> Result<Option<FlownPath>, PlotError> {
        let Some(map_topic) = topic_of::<ObstacleMap>(log, "obstacle_map") else { return Ok(None) };
        let Some(map) = log.read::<ObstacleMap>(&map_topic)?.into_iter().next().map(|r| r.message) else {
            return Ok(None);
        };
        let Some(truth_topic) = topic_of::<GroundTruth>(log, "ground_truth") else { return Ok(None) };
        if map.obstacles.is_empty() {
            return Ok(None);
        }
        let truth: Vec<_> = log.read::<GroundTruth>(&truth_topic)?;
        if truth.is_empty() {
            return Ok(None);
        }

        let mut path = FlownPath {
            truth: Vec::with_capacity(truth.len()),
            setpoints: Vec::new(),
            collisions: Vec::new(),
            collision_count: 0,
            min_clearance_m: None,
            map,
        };
        for record in &truth {
            let g = &record.message;
            let point =
                PathPoint { t_s: series.clock.secs(record.publish_time), position_ned_m: g.position_ned_m };
            if g.collisions > path.collision_count {
                path.collisions.push(point);
            }
            path.collision_count = g.collisions;
            if let Some(clearance) = g.clearance_m {
                path.min_clearance_m =
                    Some(path.min_clearance_m.map_or(clearance, |m: f64| m.min(clearance)));
            }
            path.truth.push(point);
        }
        path.truth.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));

        if let Some(topic) = topic_of::<Setpoint>(log, "setpoint") {
            let (estimator, map_frame) = (LocalFrame::new(series.origin), LocalFrame::new(path.map.home));
            path.setpoints = log
                .read::<Setpoint>(&topic)?
                .iter()
                .filter_map(|record| {
                    let SetpointTarget::Trajectory(t) = record.message.target else { return None };
                    let [Some(n), Some(e), Some(d)] = t.position_ned_m else { return None };
                    record.message.armed.then(|| PathPoint {
                        t_s: series.clock.secs(record.publish_time),
                        position_ned_m: map_frame.to_ned(estimator.to_geodetic([n, e, d])),
                    })
                })
                .collect();
        }
        Ok(Some(path))
    }

    /// Horizontal distance flown along the true path at each truth sample (m).
    pub fn along_track_m(&self) -> Vec<f64> {
        let mut travelled = 0.0;
        let mut previous: Option<[f64; 3]> = None;
        self.truth
            .iter()
            .map(|p| {
                if let Some(q) = previous {
                    travelled += (p.position_ned_m[0] - q[0]).hypot(p.position_ned_m[1] - q[1]);
                }
                previous = Some(p.position_ned_m);
                travelled
            })
            .collect()
    }

    /// The distance along the true path (m) the vehicle had flown at `t_s`.
    pub fn along_track_at(&self, along_m: &[f64], t_s: f64) -> f64 {
        let i = self.truth.partition_point(|p| p.t_s < t_s).min(along_m.len().saturating_sub(1));
        along_m.get(i).copied().unwrap_or(0.0)
    }

    /// Stretches of the true path (start and end, m along the track) that pass within
    /// `corridor_m` horizontally of each obstacle: what the side view shows beside the path.
    pub fn obstacles_beside(&self, along_m: &[f64], corridor_m: f64) -> Vec<(&Obstacle, f64, f64)> {
        let mut stretches = Vec::new();
        for obstacle in &self.map.obstacles {
            let mut open: Option<f64> = None;
            for (p, &s) in self.truth.iter().zip(along_m) {
                let ne = (p.position_ned_m[0], p.position_ned_m[1]);
                let near = footprint::horizontal_distance_m(obstacle, ne) <= corridor_m;
                match (near, open) {
                    (true, None) => open = Some(s),
                    (false, Some(start)) => {
                        stretches.push((obstacle, start, s));
                        open = None;
                    }
                    _ => {}
                }
            }
            if let (Some(start), Some(&end)) = (open, along_m.last()) {
                stretches.push((obstacle, start, end));
            }
        }
        stretches
    }
}
