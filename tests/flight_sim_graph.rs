//! The default graph (`config/sim.toml`) run in-process on the lockstep clock.

use std::path::{Path, PathBuf};
use std::time::Duration;

use kestrel::{LoadedConfig, Registry, RunOptions, run};
use support::flights;

mod support;

fn temp_path(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("kestrel-{}-{name}", std::process::id()))
}

/// Topics whose content is a function of the flight alone. `control_loop_stats` is left out:
/// it reports how long each loop iteration took on the host's wall clock.
const FLIGHT_TOPICS: [&str; 12] = [
    "imu",
    "gps",
    "baro",
    "mag",
    "ground_truth",
    "battery",
    "nav_state",
    "estimator_status",
    "setpoint",
    "vehicle_status",
    "actuator_outputs",
    "supervisor",
];

/// Flies the square mission from take-off to landing and records it.
fn record_mission(path: &Path) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("config");
    let mut config = LoadedConfig::load(&dir.join("sim.toml")).unwrap();
    flights::without_link_sockets(&mut config);
    let commander = config.graph.actors.values_mut().find(|d| d.kind.get_ref() == "commander").unwrap();
    let mut params = toml::Table::new();
    params.insert("mission".into(), dir.join("missions/square.plan").display().to_string().into());
    params.insert("auto".into(), true.into());
    params.insert("exit_on_land".into(), true.into());
    commander.params = Some(toml::Spanned::new(0..0, params));
    config.graph.record.topics =
        FLIGHT_TOPICS.iter().map(|t| toml::Spanned::new(0..0, (*t).to_owned())).collect();
    let options = RunOptions {
        duration: Some(Duration::from_secs(300)),
        speedup: Some(0.0),
        record: Some(path.to_owned()),
        ..Default::default()
    };
    let report = run(&config, &Registry::standard(), options).unwrap();
    assert!(report.supervisor_events.is_empty(), "{:?}", report.supervisor_events);
    assert!(report.mailboxes.iter().all(|m| m.overflowed == 0), "{:?}", report.mailboxes);
    assert!(report.end_time.as_secs_f64() < 120.0, "the mission ends on landing, at {}", report.end_time);
}

#[test]
fn lockstep_flight_records_bit_identical_logs_twice() {
    let (a, b) = (temp_path("det-a.mcap"), temp_path("det-b.mcap"));
    record_mission(&a);
    record_mission(&b);
    let (bytes_a, bytes_b) = (std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    let _ = (std::fs::remove_file(&a), std::fs::remove_file(&b));
    assert!(bytes_a.len() > 1_000_000, "a whole mission is logged ({} bytes)", bytes_a.len());
    assert!(bytes_a == bytes_b, "two lockstep flights differ ({} vs {} bytes)", bytes_a.len(), bytes_b.len());
}

/// The estimator's drag model in config/sim.toml is the simulated vehicle's `[drag]` per unit
/// mass: the two live in different files (the estimator knows no vehicle file), so this ties
/// them. A change to one alone would make drag fusion read a wrong airspeed after a GPS loss.
#[test]
fn the_sim_graphs_estimator_drag_model_is_its_vehicles_drag_per_unit_mass() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/sim.toml");
    let config = LoadedConfig::load(&path).expect("config/sim.toml loads");
    let actors = &config.merged["actors"];
    let estimator: kestrel_estimator::EkfParams =
        actors["estimator"]["params"].clone().try_into().expect("estimator params");
    let vehicle_file = config.merged["vehicle"].as_str().expect("the graph names its vehicle file");
    let vehicle = kestrel_sim::VehicleParams::load(&path.parent().expect("config dir").join(vehicle_file))
        .expect("the vehicle file loads");
    let linear = vehicle.drag.linear_n_per_m_s / vehicle.mass_kg;
    let quadratic = vehicle.drag.quadratic_n_per_m2_s2 / vehicle.mass_kg;
    assert!(
        (estimator.drag_linear_per_s - linear).abs() < 1e-12,
        "{} vs {linear}",
        estimator.drag_linear_per_s
    );
    assert!(
        (estimator.drag_quadratic_per_m - quadratic).abs() < 1e-12,
        "{} vs {quadratic}",
        estimator.drag_quadratic_per_m
    );
}
