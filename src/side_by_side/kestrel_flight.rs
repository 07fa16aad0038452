//! Kestrel's own stack on a row: config/sim.toml on the row's vehicle (with ArduCopter SITL's
//! sensor defaults) and world, `kestrel run --auto` on the plan in lockstep until it lands, scored
//! on the ground truth and `nav_state` of its flight log.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use kestrel_proto::messages::{BatteryStatus, GroundTruth, NavState};
use serde_json::Value;

use super::score::{Estimate, PlannedPath, Truth, euler_rad, ne_from, score};
use super::{Flown, SEED, Scenario, Tools};
use crate::recorder::LogReader;

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
/// without `[sensors]` tables takes the code's defaults, which are `quad_x`'s tables: those are
/// written out first.
fn vehicle_with_ardupilot_sensors(vehicle: &Path, quad_x: &Path) -> Result<String, String> {
    let read = |p: &Path| std::fs::read_to_string(p).map_err(|e| format!("{}: {e}", p.display()));
    let mut text = read(vehicle)?;
    if !text.contains("\n[sensors") {
        let quad = read(quad_x)?;
        let sensors =
            quad.find("\n[sensors]").ok_or_else(|| format!("{}: no [sensors]", quad_x.display()))?;
        text += &quad[sensors..];
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
        let key = key.rsplit('.').next().unwrap_or(key);
        if !out.contains(&format!("{key} = {value}")) {
            return Err(format!("{}: no `{key}` to set", vehicle.display()));
        }
    }
    Ok(out)
}

/// `world`'s text with every `at_s` of its `[[faults]]` moved `offset_s` later.
fn shifted_faults(world: &Path, offset_s: f64) -> Result<String, String> {
    let text = std::fs::read_to_string(world).map_err(|e| format!("{}: {e}", world.display()))?;
    let mut out = String::new();
    for (i, line) in text.lines().enumerate() {
        match line.trim_start().strip_prefix("at_s") {
            Some(rest) if offset_s != 0.0 => {
                let value = rest.trim_start_matches([' ', '=']).split('#').next().unwrap_or("").trim();
                let value: f64 = value
                    .parse()
                    .map_err(|e| format!("{}:{}: at_s {value:?}: {e}", world.display(), i + 1))?;
                out += &format!("at_s = {}\n", value + offset_s);
            }
            _ => out += &format!("{line}\n"),
        }
    }
    Ok(out)
}

/// Flies `scenario` with Kestrel's stack in `dir` (scratch: graph, vehicle, world, flight log);
/// `fault_offset_s` is added to the world's fault times (for a row whose faults count from
/// take-off: Kestrel's take-off time).
pub fn fly_kestrel(
    tools: &Tools,
    scenario: &Scenario,
    dir: &Path,
    fault_offset_s: f64,
) -> Result<Flown, String> {
    let started = Instant::now();
    let config_dir = tools.repo.join("config");
    let write = |p: &Path, text: &str| std::fs::write(p, text).map_err(|e| format!("{}: {e}", p.display()));
    let vehicle = dir.join("vehicle.toml");
    write(
        &vehicle,
        &vehicle_with_ardupilot_sensors(&scenario.vehicle, &config_dir.join("vehicles/quad_x.toml"))?,
    )?;
    let world = dir.join("world.toml");
    write(&world, &shifted_faults(&scenario.world, fault_offset_s)?)?;
    let sim = config_dir.join("sim.toml");
    let merged = crate::LoadedConfig::load(&sim)
        .map_err(|e| e.to_string())?
        .merged_toml()
        .map_err(|e| format!("{}: {e}", sim.display()))?;
    // No fixed sockets: rows and other runs fly side by side.
    let link = "[actors.link]\ntype = \"link\"\n";
    if !merged.contains(link) {
        return Err(format!("{}: no [actors.link] with a type", sim.display()));
    }
    let graph = merged
        .replace(
            link,
            &format!("{link}params.endpoints = [{{ type = \"udp_in\", bind = \"127.0.0.1:0\" }}]\n"),
        )
        .replace(
            "vehicle = \"vehicles/quad_x.toml\"",
            &format!("vehicle = {:?}", vehicle.display().to_string()),
        )
        .replace("world = \"worlds/empty.toml\"", &format!("world = {:?}", world.display().to_string()));
    if graph.contains("\"vehicles/") || graph.contains("\"worlds/") {
        return Err(format!("{}: a vehicle or world path was not replaced", sim.display()));
    }
    // The seed ArduCopter's physics gets too: the same gust draw for both stacks.
    if !graph.contains(&format!("seed = {SEED}")) {
        return Err(format!("{}: the simulator's seed is not {SEED}", sim.display()));
    }
    let config = dir.join("graph.toml");
    write(&config, &graph)?;
    let log = dir.join("flight.mcap");
    let report_path = dir.join("report.json");
    let out = Command::new(&tools.kestrel)
        .current_dir(&tools.repo)
        .env_remove("RUST_LOG")
        .args(["run", "--speedup", "0", "--quiet", "--config"])
        .arg(&config)
        .args(["--auto", "--exit-on-land", "--mission"])
        .arg(&scenario.plan)
        .args(["--duration", "400", "--record"])
        .arg(&log)
        .arg("--report")
        .arg(&report_path)
        .output()
        .map_err(|e| format!("start {}: {e}", tools.kestrel.display()))?;
    if !out.status.success() {
        return Err(format!(
            "{}: kestrel run {}: {}",
            scenario.name,
            out.status,
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    let report: Value = std::fs::read_to_string(&report_path)
        .map_err(|e| e.to_string())
        .and_then(|t| serde_json::from_str(&t).map_err(|e| e.to_string()))
        .map_err(|e| format!("{}: {e}", report_path.display()))?;
    let reader = LogReader::open(&log).map_err(|e| format!("{}: {e}", log.display()))?;
    let truth: Vec<Truth> = reader
        .read::<GroundTruth>("ground_truth")
        .map_err(|e| format!("{}: ground_truth: {e}", log.display()))?
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
        .map_err(|e| format!("{}: battery: {e}", log.display()))?
        .into_iter()
        .map(|r| (r.message.time.0 as f64 * 1e-6, r.message.voltage_v, r.message.current_a))
        .collect();
    let home = kestrel_sim::World::load(&world).map_err(|e| e.to_string())?.home;
    let estimates: Vec<Estimate> = reader
        .read::<NavState>("nav_state")
        .map_err(|e| format!("{}: nav_state: {e}", log.display()))?
        .into_iter()
        .filter_map(|r| {
            let n = r.message;
            let origin = n.origin?;
            // The estimator's frame sits at its origin; home's NED is that plus the origin's offset.
            let (dn, de) = ne_from((home.lat_deg, home.lon_deg), origin.lat_deg, origin.lon_deg);
            let dd = home.alt_msl_m - origin.alt_m;
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
        &PlannedPath::read(&scenario.plan)?,
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
    Ok(Flown { score, wall_s: started.elapsed().as_secs_f64() })
}
