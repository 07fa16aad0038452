//! The same flight with both stacks: one mission (QGC `.plan`), one world and one vehicle flown
//! by Kestrel's own stack in the lockstep simulator (`kestrel run --auto --record`) and by
//! ArduCopter SITL on the same simulator (`kestrel sitl ardupilot --trace`, a ground station
//! script arming it), each scored the same way on the simulator's truth:
//!
//! * tracking: horizontal distance of the true position from the planned path (the polyline
//!   home → each waypoint → where the plan lands, placed as the simulator places latitude and
//!   longitude: WGS-84, the tangent plane at home), RMS and worst, over every airborne sample;
//! * estimate: the stack's own position, velocity and attitude against the truth of the same
//!   instant, airborne (Kestrel's `nav_state` in its log; ArduCopter's LOCAL_POSITION_NED and
//!   ATTITUDE, stamped with its boot time, which is the physics time the backend sent it);
//! * time from take-off to the last touchdown, landing error from where the plan lands, energy
//!   drawn from the simulated battery (∫ V·I dt, Wh) over the same span, and the outcome.
//!
//! Kestrel's simulated sensors are given ArduCopter SITL's sensor defaults for the comparison
//! ([`ardupilot_sensor_defaults`]).

use std::collections::BTreeMap;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use kestrel::recorder::LogReader;
use kestrel_proto::geo::{Geodetic, LocalFrame};
use kestrel_proto::messages::{BatteryStatus, GroundTruth, NavState};
use serde_json::Value;

use super::arducopter;
use super::flights::{merged_graph, repo, run_for_report};
use super::sim_vehicle::{Proc, python_client, stop, tail, transcript_until_exit};

/// One row of the comparison: what to fly, and where.
#[derive(Clone, Debug)]
pub struct Scenario {
    /// The row's name on the page.
    pub name: &'static str,
    /// The QGC plan, relative to the repository.
    pub plan: &'static str,
    /// The world file, relative to the repository.
    pub world: &'static str,
    /// Kestrel's vehicle file, relative to the repository (ArduCopter flies the same through
    /// its SITL config).
    pub vehicle: &'static str,
    /// ArduCopter's parameter file for the frame (config/ardupilot/), relative to the
    /// repository; config/ardupilot/side-by-side.parm follows it.
    pub parm: &'static str,
    /// The world's `[[faults]]` count from take-off (see [`Scenario::kestrel_fault_offset_s`]).
    pub faults_from_take_off: bool,
}

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
fn ne_from(home: (f64, f64), lat_deg: f64, lon_deg: f64) -> (f64, f64) {
    let frame = LocalFrame::new(Geodetic { lat_deg: home.0, lon_deg: home.1, alt_m: 0.0 });
    let [n, e, _] = frame.to_ned(Geodetic { lat_deg, lon_deg, alt_m: 0.0 });
    (n, e)
}

impl PlannedPath {
    /// Home, each waypoint, and where the plan lands (home for RTL, a LAND item's position).
    pub fn read(plan: &Path) -> PlannedPath {
        let json: Value = serde_json::from_str(&std::fs::read_to_string(plan).unwrap()).unwrap();
        let mission = &json["mission"];
        let home_list = mission["plannedHomePosition"].as_array().expect("plannedHomePosition");
        let home = (home_list[0].as_f64().unwrap(), home_list[1].as_f64().unwrap());
        let mut vertices = vec![(0.0, 0.0)];
        let mut landing = (0.0, 0.0);
        let mut take_off_alt_m = 10.0;
        for item in mission["items"].as_array().expect("items") {
            let params = item["params"].as_array().expect("params");
            let number = |i: usize| params[i].as_f64().unwrap_or(0.0);
            match item["command"].as_u64().expect("command") {
                22 => take_off_alt_m = number(6),
                16 => vertices.push(ne_from(home, number(4), number(5))),
                20 => landing = (0.0, 0.0),
                21 => landing = ne_from(home, number(4), number(5)),
                other => panic!("{}: command {other} is not scored", plan.display()),
            }
        }
        vertices.push(landing);
        PlannedPath { vertices_ne_m: vertices, landing_ne_m: landing, take_off_alt_m }
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
    let Some(take_off) = take_off else {
        return Score { outcome: "never took off".into(), ..Score::default() };
    };
    let last_airborne = truth.iter().rposition(|s| !s.landed).unwrap();
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
    let end = truth.last().unwrap();
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

/// ArduCopter SITL's own sensor defaults (its `SIM_*` parameters as ArduPilot's autotest
/// copter.parm leaves them, read back from the 4.7 binary): `SIM_GYR1_RND` 0, `SIM_ACC1_RND` 0,
/// `SIM_GPS1_NOISE` 0 at `SIM_GPS1_HZ` 5 with `SIM_GPS1_LAG_MS` 100, `SIM_BARO_RND` 0,
/// `SIM_MAG_RND` 0, and no IMU bias walk. Applied to a Kestrel vehicle file's `[sensors]`: the
/// keys and the values they get.
pub fn ardupilot_sensor_defaults() -> [(&'static str, &'static str); 11] {
    [
        ("gyro_noise_rad_s", "0.0"),
        ("accel_noise_m_s2", "0.0"),
        ("gyro_bias_walk_rad_s_per_sqrt_s", "0.0"),
        ("accel_bias_walk_m_s2_per_sqrt_s", "0.0"),
        ("horizontal_noise_m", "0.0"),
        ("vertical_noise_m", "0.0"),
        ("velocity_noise_m_s", "0.0"),
        ("pressure_noise_pa", "0.0"),
        ("noise_gauss", "0.0"),
        // The GPS table's lag (the only `lag_s` set apart below) and rate.
        ("gps.lag_s", "0.1"),
        ("gps.rate_hz", "5.0"),
    ]
}

/// `vehicle`'s text with [`ardupilot_sensor_defaults`] in place of its sensor noise. A file
/// without `[sensors]` tables takes the code's defaults, which are quad_x.toml's tables: those
/// are written out first.
fn vehicle_with_ardupilot_sensors(vehicle: &Path) -> String {
    let mut text = std::fs::read_to_string(vehicle).unwrap();
    if !text.contains("\n[sensors") {
        let quad = std::fs::read_to_string(repo().join("config/vehicles/quad_x.toml")).unwrap();
        text += &quad[quad.find("\n[sensors]").expect("quad_x.toml's [sensors]")..];
    }
    let mut out = String::new();
    let mut table = String::new();
    for line in text.lines() {
        let trimmed = line.trim_start();
        if trimmed.starts_with('[') {
            table = trimmed.trim_matches(|c| c == '[' || c == ']').to_string();
        }
        let key = trimmed.split('=').next().unwrap_or("").trim();
        let replaced = ardupilot_sensor_defaults().iter().find_map(|(k, v)| {
            let (want_table, want_key) = match k.split_once('.') {
                Some((t, k)) => (Some(format!("sensors.{t}")), k),
                None => (None, *k),
            };
            (key == want_key && want_table.is_none_or(|t| t == table)).then_some(*v)
        });
        match replaced {
            Some(v) if trimmed.contains('=') => out += &format!("{key} = {v}\n"),
            _ => out += &format!("{line}\n"),
        }
    }
    for (key, value) in ardupilot_sensor_defaults() {
        let key = key.rsplit('.').next().unwrap();
        assert!(out.contains(&format!("{key} = {value}")), "{}: no `{key}` to set", vehicle.display());
    }
    out
}

/// What one side of a row flew.
pub struct Flown {
    pub score: Score,
    /// Wall time of the run (s), for the log only.
    pub wall_s: f64,
}

/// Kestrel's own stack: config/sim.toml on `scenario`'s vehicle (with ArduCopter SITL's sensor
/// defaults) and world, `--auto` on the plan until it lands. `fault_offset_s` is added to the
/// world's fault times (for [`Scenario::faults_from_take_off`], Kestrel's take-off time).
pub fn fly_kestrel(scenario: &Scenario, dir: &Path, fault_offset_s: f64) -> Flown {
    let started = Instant::now();
    let vehicle = dir.join("vehicle.toml");
    std::fs::write(&vehicle, vehicle_with_ardupilot_sensors(&repo().join(scenario.vehicle))).unwrap();
    let world = dir.join("world.toml");
    std::fs::write(&world, shifted_faults(&repo().join(scenario.world), fault_offset_s)).unwrap();
    let graph = merged_graph("sim.toml")
        .replace(
            "vehicle = \"vehicles/quad_x.toml\"",
            &format!("vehicle = {:?}", vehicle.display().to_string()),
        )
        .replace("world = \"worlds/empty.toml\"", &format!("world = {:?}", world.display().to_string()));
    assert!(!graph.contains("\"vehicles/") && !graph.contains("\"worlds/"), "paths made absolute");
    let config = dir.join("graph.toml");
    std::fs::write(&config, graph).unwrap();
    let log = dir.join("flight.mcap");
    let plan = repo().join(scenario.plan).display().to_string();
    let report = run_for_report(
        scenario.name,
        &config,
        &[
            "--auto",
            "--exit-on-land",
            "--mission",
            &plan,
            "--duration",
            "400",
            "--record",
            &log.display().to_string(),
        ],
    );
    let reader = LogReader::open(&log).unwrap();
    let truth: Vec<Truth> = reader
        .read::<GroundTruth>("ground_truth")
        .unwrap()
        .into_iter()
        .map(|r| {
            let g = r.message;
            Truth {
                t_s: g.time.0 as f64 * 1e-6,
                ned_m: g.position_ned_m,
                vel_m_s: g.velocity_ned_m_s,
                attitude: g.attitude,
                landed: g.landed,
            }
        })
        .collect();
    let battery: Vec<(f64, f64, f64)> = reader
        .read::<BatteryStatus>("battery")
        .unwrap()
        .into_iter()
        .map(|r| (r.message.time.0 as f64 * 1e-6, r.message.voltage_v, r.message.current_a))
        .collect();
    let home = {
        let w = kestrel_sim::World::load(&world).unwrap();
        (w.home.lat_deg, w.home.lon_deg, w.home.alt_msl_m)
    };
    let estimates: Vec<Estimate> = reader
        .read::<NavState>("nav_state")
        .unwrap()
        .into_iter()
        .filter_map(|r| {
            let n = r.message;
            let origin = n.origin?;
            // The estimator's frame sits at its origin; home's NED is that plus the origin's offset.
            let (dn, de) = ne_from((home.0, home.1), origin.lat_deg, origin.lon_deg);
            let dd = home.2 - origin.alt_m;
            let p = n.position_ned_m;
            Some(Estimate {
                t_s: n.time.0 as f64 * 1e-6,
                ned_m: Some([p[0] + dn, p[1] + de, p[2] + dd]),
                vel_m_s: Some(n.velocity_ned_m_s),
                euler_rad: Some(euler_rad(n.attitude)),
            })
        })
        .collect();
    let flight = &report["flight"];
    let mut score = score(
        &PlannedPath::read(&repo().join(scenario.plan)),
        &truth,
        &battery,
        &estimates,
        flight["crashed"].as_bool().unwrap_or(true),
        flight["collisions"].as_u64().unwrap_or(0),
    );
    // A lost motor: when the commander declared it, after the simulator took it.
    let lost_at = report["faults"].as_array().and_then(|f| f.iter().find(|f| f["kind"] == "motor_lost"));
    if let (Some(lost), Some(failure)) =
        (lost_at, report["motor_failures"].as_array().and_then(|m| m.first()))
    {
        score.outcome += &format!(
            ", motor {} declared failed {:.2} s after it was lost",
            failure["motor"],
            failure["t_s"].as_f64().unwrap_or(f64::NAN) - lost["t_s"].as_f64().unwrap_or(f64::NAN)
        );
    }
    let _ = std::fs::remove_dir_all(dir);
    Flown { score, wall_s: started.elapsed().as_secs_f64() }
}

/// `world`'s text with every `at_s` of its `[[faults]]` moved `offset_s` later.
fn shifted_faults(world: &Path, offset_s: f64) -> String {
    let text = std::fs::read_to_string(world).unwrap();
    text.lines()
        .map(|line| match line.trim_start().strip_prefix("at_s") {
            Some(rest) if offset_s != 0.0 => {
                let value: f64 =
                    rest.trim_start_matches([' ', '=']).split('#').next().unwrap().trim().parse().unwrap();
                format!("at_s = {}\n", value + offset_s)
            }
            _ => format!("{line}\n"),
        })
        .collect()
}

/// ArduCopter still armed this long (s of its time) on the ground after the mission is disarmed
/// by the script, and the outcome says so: ArduCopter's land detector wants its motors at the
/// lower limit and little acceleration for a second (`LAND_DETECTOR_TRIGGER_SEC`), which in
/// gusts it may never see.
const GROUND_DISARM_S: f64 = 30.0;

/// The ground station script that flies ArduCopter (tests/python/ardupilot_square.py).
const SCRIPT: &str = "ardupilot_square.py";

/// ArduCopter SITL on Kestrel's physics (`kestrel sitl ardupilot --trace`) flown through the plan
/// by the ground station script, scored on the simulator's truth trace.
pub fn fly_arducopter(binary: &Path, scenario: &Scenario, dir: &Path, limit: Duration) -> Flown {
    let plan_path = repo().join(scenario.plan);
    let plan = PlannedPath::read(&plan_path);
    let env = [
        ("PLAN", plan_path.display().to_string()),
        ("DEADLINE_S", limit.as_secs().to_string()),
        ("TAKEOFF_M", plan.take_off_alt_m.to_string()),
        ("ESTIMATE", "1".to_string()),
        ("GROUND_DISARM_S", GROUND_DISARM_S.to_string()),
    ];
    let (mut client, lines) = python_client(SCRIPT, |c| c.envs(env.iter().map(|(k, v)| (k, v))));
    let first = lines.recv_timeout(Duration::from_secs(15)).unwrap_or_default();
    let port: u16 = first.strip_prefix("PORT ").and_then(|p| p.trim().parse().ok()).expect("client port");
    let started = Instant::now();
    let (instance, _lock) = arducopter::free_instance();
    let (summary_path, trace_path, log_path) =
        (dir.join("summary.json"), dir.join("trace.json"), dir.join("kestrel-sitl.log"));
    let log = File::create(&log_path).unwrap();
    let sitl = dir.join("sitl.toml");
    let path = |p: &str| format!("{:?}", repo().join(p).display().to_string());
    std::fs::write(
        &sitl,
        format!(
            "vehicle = {}\nworld = {}\nseed = 1\nframe_rate_hz = 1200.0\ndefaults = [{}, {}]\nspeedup = 100.0\n",
            path(scenario.vehicle),
            path(scenario.world),
            path(scenario.parm),
            path("config/ardupilot/side-by-side.parm")
        ),
    )
    .unwrap();
    let mut command = Command::new(env!("CARGO_BIN_EXE_kestrel"));
    command
        .args(["sitl", "ardupilot", "--config"])
        .arg(&sitl)
        .args(["--gcs", &format!("udpclient:127.0.0.1:{port}"), "--instance", &instance.to_string()])
        .arg("--summary")
        .arg(&summary_path)
        .arg("--trace")
        .arg(&trace_path)
        .arg("--dir")
        .arg(dir.join("sitl"))
        .env(arducopter::ENV, binary)
        .stdin(Stdio::null())
        .stdout(log.try_clone().unwrap())
        .stderr(log);
    if scenario.faults_from_take_off {
        command.arg("--faults-from-take-off");
    }
    let mut kestrel = Proc(command.spawn().expect("start kestrel sitl ardupilot"));
    let (exit, transcript) = transcript_until_exit(&mut client, &lines, || {
        started.elapsed() > limit || kestrel.0.try_wait().ok().flatten().is_some()
    });
    let label = format!("{} (ArduCopter)", scenario.name);
    let logs = || {
        format!(
            "kestrel:\n{}\nSITL:\n{}",
            tail(&std::fs::read_to_string(&log_path).unwrap_or_default(), 20),
            tail(&std::fs::read_to_string(dir.join("sitl/arducopter.log")).unwrap_or_default(), 30)
        )
    };
    // The physics first, so its summary and trace are written whatever the client said.
    let status = stop(&mut kestrel, &label);
    let summary_text = std::fs::read_to_string(&summary_path).unwrap_or_default();
    assert!(
        exit.is_some_and(|s| s.success()),
        "{label}: client {exit:?}\nphysics: {summary_text}\n{}",
        logs()
    );
    assert!(status.success(), "{label}: kestrel sitl ardupilot {status}\n{}", logs());
    let wall_s = started.elapsed().as_secs_f64();
    let summary: Value = serde_json::from_str(&summary_text).unwrap();
    let trace: Vec<Value> = serde_json::from_str(&std::fs::read_to_string(&trace_path).unwrap()).unwrap();
    let triple = |v: &Value| [0, 1, 2].map(|i| v[i].as_f64().unwrap());
    let truth: Vec<Truth> = trace
        .iter()
        .map(|s| Truth {
            t_s: s["t_s"].as_f64().unwrap(),
            ned_m: triple(&s["position_ned_m"]),
            vel_m_s: triple(&s["velocity_ned_m_s"]),
            attitude: [0, 1, 2, 3].map(|i| s["attitude"][i].as_f64().unwrap()),
            landed: s["landed"].as_bool().unwrap(),
        })
        .collect();
    let battery: Vec<(f64, f64, f64)> = trace
        .iter()
        .map(|s| {
            (s["t_s"].as_f64().unwrap(), s["voltage_v"].as_f64().unwrap(), s["current_a"].as_f64().unwrap())
        })
        .collect();
    let last_line = transcript.last().expect("a result line");
    std::fs::write(dir.join("client.json"), last_line).unwrap();
    let result: Value = serde_json::from_str(last_line).unwrap();
    let results = &result["results"];
    // ArduCopter's boot clock is the physics time: SITL advances it by the differences of the
    // timestamps it is sent, from the first one (`SIM_JSON.cpp`).
    let mut estimates: BTreeMap<u64, Estimate> = BTreeMap::new();
    for p in results["local_position_ned"].as_array().expect("local_position_ned") {
        let f = |i: usize| p[i].as_f64().unwrap();
        let e = estimates.entry(p[0].as_u64().unwrap()).or_insert(Estimate {
            t_s: f(0) / 1000.0,
            ned_m: None,
            vel_m_s: None,
            euler_rad: None,
        });
        e.ned_m = Some([f(1), f(2), f(3)]);
        e.vel_m_s = Some([f(4), f(5), f(6)]);
    }
    for a in results["attitude"].as_array().expect("attitude") {
        let f = |i: usize| a[i].as_f64().unwrap();
        let e = estimates.entry(a[0].as_u64().unwrap()).or_insert(Estimate {
            t_s: f(0) / 1000.0,
            ned_m: None,
            vel_m_s: None,
            euler_rad: None,
        });
        e.euler_rad = Some([f(1), f(2), f(3)]);
    }
    let estimates: Vec<Estimate> = estimates.into_values().collect();
    let mut score = score(
        &plan,
        &truth,
        &battery,
        &estimates,
        summary["crashed"].as_bool().unwrap_or(true),
        summary["collisions"].as_u64().unwrap_or(0),
    );
    if let Some(after_s) = results["forced_disarm_after_s"].as_f64() {
        score.outcome +=
            &format!(", still armed {after_s:.0} s after touchdown (disarmed by the ground station)");
    }
    let _ = std::fs::remove_dir_all(dir);
    Flown { score, wall_s }
}

/// Where scratch files of a row go (removed once the flight is scored; kept when it fails).
pub fn row_dir(name: &str, stack: &str) -> PathBuf {
    let slug: String = name.chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '-' }).collect();
    super::flights::scratch("side-by-side", &format!("{slug}-{stack}"))
}
