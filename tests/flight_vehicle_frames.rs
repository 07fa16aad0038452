//! One vehicle file for the simulator and the controller: config/sim.toml with nothing changed
//! but its top-level `vehicle` flies the hexa and the octo (take off to 10 m, hold 5 s, 20 m
//! north, land there) in lockstep with the EKF, the commander and the controller in the loop; and
//! a graph whose controller is told another airframe than the vehicle's stops at start with an
//! error naming both, before anything flies.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

mod support;
use qgc_plan::Item;
use support::qgc_plan;

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The graph's vehicle line in config/sim.toml as composed.
const STOCK_VEHICLE: &str = "vehicle = \"vehicles/quad_x.toml\"\n";

/// A fresh scratch directory for one test.
fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kestrel-vehicle-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// config/sim.toml as composed, its vehicle line replaced by `vehicle_line`, `extra` appended,
/// the link on an unused local port (tests run side by side) and relative paths made absolute;
/// written into `dir`.
fn graph(dir: &Path, vehicle_line: &str, extra: &str) -> PathBuf {
    let config_dir = repo().join("config");
    let stock = kestrel::LoadedConfig::load(&config_dir.join("sim.toml")).unwrap().merged_toml().unwrap();
    let link = "[actors.link]\ntype = \"link\"\n";
    assert!(stock.contains(STOCK_VEHICLE) && stock.contains(link), "the stock graph changed:\n{stock}");
    let text = stock.replace(STOCK_VEHICLE, vehicle_line);
    // Nothing but the vehicle differs from the stock graph.
    assert_eq!(
        text.lines().filter(|l| !stock.contains(l)).count(),
        usize::from(vehicle_line != STOCK_VEHICLE)
    );
    let text = text
        .replace(
            link,
            &format!("{link}params.endpoints = [{{ type = \"udp_in\", bind = \"127.0.0.1:0\" }}]\n"),
        )
        .replace("\"vehicles/", &format!("\"{}/vehicles/", config_dir.display()))
        .replace("\"worlds/", &format!("\"{}/worlds/", config_dir.display()));
    let path = dir.join("graph.toml");
    std::fs::write(&path, format!("{text}\n{extra}")).unwrap();
    path
}

/// Take off to 10 m, hold 5 s over home, fly 20 m north, land there.
fn hold_and_leg_plan(dir: &Path) -> PathBuf {
    let items = [
        Item::north(qgc_plan::TAKEOFF, 0.0, 10.0),
        Item { hold_s: 5.0, ..Item::north(qgc_plan::WAYPOINT, 0.0, 10.0) },
        Item::north(qgc_plan::WAYPOINT, 20.0, 10.0),
        Item::north(qgc_plan::LAND, 20.0, 0.0),
    ];
    qgc_plan::write(dir, "hold-and-leg.plan", &items)
}

fn kestrel_run(graph: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_kestrel"))
        .current_dir(repo())
        .env_remove("RUST_LOG")
        .args(["run", "--quiet", "--config"])
        .arg(graph)
        .args(args)
        .output()
        .unwrap()
}

/// Flies `vehicle` and returns its flight report.
fn fly(vehicle: &str) -> Value {
    let dir = temp_dir(vehicle);
    let graph = graph(&dir, &format!("vehicle = \"vehicles/{vehicle}.toml\"\n"), "");
    let plan = hold_and_leg_plan(&dir);
    let report_path = dir.join("report.json");
    let started = std::time::Instant::now();
    let mut args = vec!["--speedup", "0", "--duration", "120", "--auto", "--exit-on-land"];
    let (plan, report) = (plan.display().to_string(), report_path.display().to_string());
    args.extend(["--mission", plan.as_str(), "--report", report.as_str()]);
    let out = kestrel_run(&graph, &args);
    assert!(out.status.success(), "{vehicle}: {}", String::from_utf8_lossy(&out.stderr));
    let report: Value = serde_json::from_str(&std::fs::read_to_string(&report_path).unwrap()).unwrap();
    println!(
        "{vehicle} in {:.1} s of wall time: mission {} | flight {} | estimator {} | failsafes {}",
        started.elapsed().as_secs_f64(),
        report["mission"],
        report["flight"],
        report["estimator"],
        report["failsafes"]
    );
    report
}

/// The mission done and the vehicle down at the leg's end, intact, with no failsafe.
fn assert_flew_the_mission(vehicle: &str, report: &Value) {
    assert_eq!(report["mission"]["completed"], true, "{vehicle}: {report:#}");
    assert_eq!(report["mission"]["items_reached"], report["mission"]["items_total"], "{vehicle}");
    let flight = &report["flight"];
    assert_eq!(flight["landed"], true, "{vehicle}: did not land");
    assert_eq!(flight["crashed"], false, "{vehicle}: crashed");
    assert_eq!(flight["collisions"], 0, "{vehicle}: collided");
    assert_eq!(report["failsafes"].as_array().map(Vec::len), Some(0), "{vehicle}: {}", report["failsafes"]);
    let from_home = flight["landing_distance_from_home_m"].as_f64().expect("landing distance");
    assert!(
        (from_home - 20.0).abs() < 1.5,
        "{vehicle} landed {from_home:.2} m from home, not at the leg's end"
    );
    let rms_h = report["estimator"]["rms_horizontal_m"].as_f64().expect("estimator error");
    assert!(rms_h < 1.0, "{vehicle}: horizontal estimate error {rms_h:.2} m RMS");
}

#[test]
fn the_hexa_flies_config_sim_toml_with_only_its_vehicle_changed() {
    assert_flew_the_mission("hexa_x", &fly("hexa_x"));
}

#[test]
fn the_octo_flies_config_sim_toml_with_only_its_vehicle_changed() {
    assert_flew_the_mission("octo_x", &fly("octo_x"));
}

/// Stops at start, exit status 1, the error on stderr, no panic and nothing flown.
fn refused_at_start(graph: &Path) -> String {
    let out = kestrel_run(graph, &["--speedup", "0", "--duration", "5"]);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "started:\n{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    stderr
}

#[test]
fn a_controller_told_the_quads_airframe_on_the_hexa_is_refused_at_start_naming_both() {
    let dir = temp_dir("airframe-mismatch");
    let quad_airframe = "[actors.controller.params.control.airframe]\nmass_kg = 1.5\nframe = \"quad_x\"\n";
    let graph = graph(&dir, "vehicle = \"vehicles/hexa_x.toml\"\n", quad_airframe);
    let stderr = refused_at_start(&graph);
    for part in [
        graph.display().to_string(),
        "actor 'controller'".into(),
        "vehicles/hexa_x.toml".into(),
        "params.control.airframe.mass_kg = 1.5, the vehicle file's mass_kg = 2.4".into(),
        "params.control.airframe.frame = \"quad_x\", the vehicle file's frame = \"hexa_x\"".into(),
    ] {
        assert!(stderr.contains(&part), "no '{part}' in:\n{stderr}");
    }
}

#[test]
fn a_simulator_on_the_hexa_under_a_graph_vehicle_of_the_quad_is_refused_at_start() {
    let dir = temp_dir("two-vehicles");
    let graph = graph(&dir, STOCK_VEHICLE, "");
    let params = "[actors.sim.params]\n";
    let text = std::fs::read_to_string(&graph).unwrap();
    assert!(text.contains(params), "the composed graph writes the simulator's params as a table");
    let hexa = repo().join("config/vehicles/hexa_x.toml");
    std::fs::write(&graph, text.replace(params, &format!("{params}vehicle = \"{}\"\n", hexa.display())))
        .unwrap();
    let stderr = refused_at_start(&graph);
    for part in
        ["actor 'sim' flies", "vehicles/hexa_x.toml", "the graph's vehicle is", "vehicles/quad_x.toml"]
    {
        assert!(stderr.contains(part), "no '{part}' in:\n{stderr}");
    }
}
