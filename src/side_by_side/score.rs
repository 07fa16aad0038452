//! Scoring one flight on the simulator's truth, the same for both stacks: tracking against the
//! planned path, the stack's own estimate against the truth of the same instant, time, landing
//! error, energy and outcome. Pure: held by tests/sitl_side_by_side.rs's hand-computed flight
//! (`scoring_measures_against_the_plan_and_the_truth_of_the_same_instant`).

use std::path::Path;

use kestrel_proto::geo::{Geodetic, LocalFrame};
use serde_json::Value;

/// One stack's flight, scored.
#[derive(Clone, Debug, Default)]
pub struct Score {
    pub tracking_rms_m: f64,
    pub tracking_max_m: f64,
    pub est_horizontal_rms_m: f64,
    pub est_vertical_rms_m: f64,
    pub est_velocity_rms_m_s: f64,
    pub est_roll_pitch_rms_deg: f64,
    pub est_yaw_rms_deg: f64,
    /// Estimate samples compared.
    pub est_samples: usize,
    /// Take-off to the last touchdown (s of simulated time).
    pub flight_s: f64,
    pub landing_error_m: f64,
    /// Where it ended against where the plan lands: north, east (m).
    pub landing_offset_ne_m: (f64, f64),
    pub energy_wh: f64,
    pub take_off_s: f64,
    /// `landed`, `crashed`, or `airborne at the end`, with collisions when any.
    pub outcome: String,
    /// The true horizontal path (north, east in m from home), for the picture.
    pub path_ne_m: Vec<(f64, f64)>,
}

/// A truth sample, the same for both stacks.
#[derive(Clone, Copy, Debug)]
pub struct Truth {
    pub t_s: f64,
    pub ned_m: [f64; 3],
    pub vel_m_s: [f64; 3],
    pub attitude: [f64; 4],
    pub landed: bool,
}

/// An estimate of one instant, in home's NED frame.
#[derive(Clone, Copy, Debug)]
pub struct Estimate {
    pub t_s: f64,
    pub ned_m: Option<[f64; 3]>,
    pub vel_m_s: Option<[f64; 3]>,
    /// Roll, pitch, yaw (rad, Z-Y-X).
    pub euler_rad: Option<[f64; 3]>,
}

/// The planned path and landing point, north-east-down from the plan's home (m).
#[derive(Clone, Debug)]
pub struct PlannedPath {
    pub vertices_ne_m: Vec<(f64, f64)>,
    pub landing_ne_m: (f64, f64),
    /// The take-off item's altitude (m above home).
    pub take_off_alt_m: f64,
}

/// North and east of `lat_deg, lon_deg` from `home` (m), as the simulator converts (WGS-84, the
/// local tangent plane at home): the truth's frame.
pub fn ne_from(home: (f64, f64), lat_deg: f64, lon_deg: f64) -> (f64, f64) {
    let frame = LocalFrame::new(Geodetic { lat_deg: home.0, lon_deg: home.1, alt_m: 0.0 });
    let [n, e, _] = frame.to_ned(Geodetic { lat_deg, lon_deg, alt_m: 0.0 });
    (n, e)
}

impl PlannedPath {
    /// Home, each waypoint, and where the plan lands (home for RTL, a LAND item's position).
    /// Items other than take-off, waypoint, RTL and land are refused by name: they are not scored.
    pub fn read(plan: &Path) -> Result<PlannedPath, String> {
        let name = plan.display();
        let text = std::fs::read_to_string(plan).map_err(|e| format!("{name}: {e}"))?;
        let json: Value = serde_json::from_str(&text).map_err(|e| format!("{name}: {e}"))?;
        let mission = &json["mission"];
        let home = mission["plannedHomePosition"]
            .as_array()
            .and_then(|h| Some((h.first()?.as_f64()?, h.get(1)?.as_f64()?)))
            .ok_or_else(|| format!("{name}: mission.plannedHomePosition is not [lat, lon, alt]"))?;
        let mut vertices = vec![(0.0, 0.0)];
        let mut landing = (0.0, 0.0);
        let mut take_off_alt_m = 10.0;
        let items = mission["items"].as_array().ok_or_else(|| format!("{name}: no mission.items"))?;
        for (i, item) in items.iter().enumerate() {
            let params =
                item["params"].as_array().ok_or_else(|| format!("{name}: item {i} has no params"))?;
            let number = |k: usize| params.get(k).and_then(Value::as_f64).unwrap_or(0.0);
            match item["command"].as_u64() {
                Some(22) => take_off_alt_m = number(6),
                Some(16) => vertices.push(ne_from(home, number(4), number(5))),
                Some(20) => landing = (0.0, 0.0),
                Some(21) => landing = ne_from(home, number(4), number(5)),
                other => return Err(format!("{name}: item {i}'s command {other:?} is not scored")),
            }
        }
        vertices.push(landing);
        Ok(PlannedPath { vertices_ne_m: vertices, landing_ne_m: landing, take_off_alt_m })
    }

    /// Horizontal distance of `p` from the nearest point of the path (m).
    pub fn distance_m(&self, p: (f64, f64)) -> f64 {
        self.vertices_ne_m
            .windows(2)
            .map(|leg| {
                let (a, b) = (leg[0], leg[1]);
                let ab = (b.0 - a.0, b.1 - a.1);
                let ap = (p.0 - a.0, p.1 - a.1);
                let length_sq = ab.0 * ab.0 + ab.1 * ab.1;
                let along = if length_sq > 0.0 {
                    ((ab.0 * ap.0 + ab.1 * ap.1) / length_sq).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                (ap.0 - along * ab.0).hypot(ap.1 - along * ab.1)
            })
            .fold(f64::INFINITY, f64::min)
    }
}

/// Roll, pitch, yaw (rad, aerospace Z-Y-X) of a `[w, x, y, z]` body-to-NED quaternion.
pub fn euler_rad(q: [f64; 4]) -> [f64; 3] {
    let [w, x, y, z] = q;
    let roll = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
    let pitch = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0).asin();
    let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
    [roll, pitch, yaw]
}

/// `a − b` wrapped into (−π, π].
pub fn angle_difference_rad(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(std::f64::consts::TAU);
    if d > std::f64::consts::PI { d - std::f64::consts::TAU } else { d }
}

/// The truth at `t_s`, linearly interpolated between the samples either side (the nearer one's
/// attitude and landed flag); `None` outside the trace.
pub fn truth_at(truth: &[Truth], t_s: f64) -> Option<Truth> {
    let i = truth.partition_point(|s| s.t_s < t_s);
    if i == 0 || i >= truth.len() {
        return (truth.first().is_some_and(|s| (s.t_s - t_s).abs() < 1e-9)).then(|| truth[0]);
    }
    let (a, b) = (truth[i - 1], truth[i]);
    let f = (t_s - a.t_s) / (b.t_s - a.t_s);
    let lerp = |x: [f64; 3], y: [f64; 3]| [0, 1, 2].map(|k| x[k] + f * (y[k] - x[k]));
    let nearer = if f < 0.5 { a } else { b };
    Some(Truth { t_s, ned_m: lerp(a.ned_m, b.ned_m), vel_m_s: lerp(a.vel_m_s, b.vel_m_s), ..nearer })
}

/// Scores one flight: `truth` in time order, `battery` as (t_s, V, A), `estimates` in any order.
pub fn score(
    plan: &PlannedPath,
    truth: &[Truth],
    battery: &[(f64, f64, f64)],
    estimates: &[Estimate],
    crashed: bool,
    collisions: u64,
) -> Score {
    let take_off = truth.iter().position(|s| !s.landed);
    let (Some(take_off), Some(last_airborne)) = (take_off, truth.iter().rposition(|s| !s.landed)) else {
        return Score { outcome: "never took off".into(), ..Score::default() };
    };
    let landed = last_airborne + 1 < truth.len();
    let touchdown = truth[(last_airborne + 1).min(truth.len() - 1)];
    let (t0, t1) = (truth[take_off].t_s, touchdown.t_s);
    let airborne = &truth[take_off..=last_airborne];
    let distances: Vec<f64> = airborne.iter().map(|s| plan.distance_m((s.ned_m[0], s.ned_m[1]))).collect();
    let rms = |sum: f64, n: usize| if n == 0 { f64::NAN } else { (sum / n as f64).sqrt() };
    let tracking_rms_m = rms(distances.iter().map(|d| d * d).sum(), distances.len());
    let tracking_max_m = distances.iter().copied().fold(0.0, f64::max);

    let mut sums = [0.0; 5];
    let mut counts = [0usize; 3];
    for e in estimates.iter().filter(|e| e.t_s >= t0 && e.t_s <= truth[last_airborne].t_s) {
        let Some(t) = truth_at(truth, e.t_s) else { continue };
        if let Some(p) = e.ned_m {
            sums[0] += (p[0] - t.ned_m[0]).powi(2) + (p[1] - t.ned_m[1]).powi(2);
            sums[1] += (p[2] - t.ned_m[2]).powi(2);
            counts[0] += 1;
        }
        if let Some(v) = e.vel_m_s {
            sums[2] += (0..3).map(|k| (v[k] - t.vel_m_s[k]).powi(2)).sum::<f64>();
            counts[1] += 1;
        }
        if let Some(a) = e.euler_rad {
            let tru = euler_rad(t.attitude);
            sums[3] += (angle_difference_rad(a[0], tru[0]).powi(2)
                + angle_difference_rad(a[1], tru[1]).powi(2))
                / 2.0;
            sums[4] += angle_difference_rad(a[2], tru[2]).powi(2);
            counts[2] += 1;
        }
    }
    // ∫ V·I dt over take-off to touchdown, trapezoidal over the battery samples (Wh).
    let in_flight: Vec<&(f64, f64, f64)> = battery.iter().filter(|b| b.0 >= t0 && b.0 <= t1).collect();
    let energy_j: f64 =
        in_flight.windows(2).map(|w| 0.5 * (w[0].1 * w[0].2 + w[1].1 * w[1].2) * (w[1].0 - w[0].0)).sum();
    let end = truth[truth.len() - 1];
    let mut outcome = if crashed {
        "crashed".to_string()
    } else if landed {
        "landed".to_string()
    } else {
        "airborne at the end".to_string()
    };
    if collisions > 0 {
        outcome += &format!(", {collisions} collisions");
    }
    Score {
        tracking_rms_m,
        tracking_max_m,
        est_horizontal_rms_m: rms(sums[0], counts[0]),
        est_vertical_rms_m: rms(sums[1], counts[0]),
        est_velocity_rms_m_s: rms(sums[2], counts[1]),
        est_roll_pitch_rms_deg: rms(sums[3], counts[2]).to_degrees(),
        est_yaw_rms_deg: rms(sums[4], counts[2]).to_degrees(),
        est_samples: counts[0].min(counts[2]),
        flight_s: t1 - t0,
        landing_error_m: (end.ned_m[0] - plan.landing_ne_m.0).hypot(end.ned_m[1] - plan.landing_ne_m.1),
        landing_offset_ne_m: (end.ned_m[0] - plan.landing_ne_m.0, end.ned_m[1] - plan.landing_ne_m.1),
        energy_wh: energy_j / 3600.0,
        take_off_s: t0,
        outcome,
        path_ne_m: airborne.iter().map(|s| (s.ned_m[0], s.ned_m[1])).collect(),
    }
}
