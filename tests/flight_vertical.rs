//! Vertical avoidance in closed-loop lockstep flights of the default graph (`config/sim.toml`,
//! whose vehicle carries an up- and a downward rangefinder): a take-off under a slab
//! stops below it and the mission goes on from there, and a landing onto a roof moves off the
//! roof and lands on the ground beside it. Each scenario is also flown by the same vehicle
//! without rangefinders, which must hit the slab or land on the roof: the test's own proof that
//! the scenario needs what it tests.

use std::path::{Path, PathBuf};

use serde_json::Value;

mod support;
use flights::{clearance_m, collisions, merged_graph, repo, run_for_report, scratch};
use qgc_plan::Item;
use support::{flights, qgc_plan};

/// Writes a world of `obstacles` (`[[obstacles]]` tables) and `config/sim.toml` (its bases
/// merged in) flying it into `dir`, with the vehicle's rangefinders or without them; returns the
/// graph's path.
fn graph(dir: &Path, obstacles: &str, rangefinders: bool) -> PathBuf {
    let config_dir = repo().join("config");
    let world = dir.join("world.toml");
    let empty = std::fs::read_to_string(config_dir.join("worlds/empty.toml")).unwrap();
    std::fs::write(&world, format!("{empty}\n{obstacles}")).unwrap();
    let vehicle_text = std::fs::read_to_string(config_dir.join("vehicles/quad_x.toml")).unwrap();
    assert!(
        vehicle_text.contains("[sensors.rangefinder_up]")
            && vehicle_text.contains("[sensors.rangefinder_down]")
    );
    let vehicle = dir.join("vehicle.toml");
    let vehicle_text = if rangefinders { vehicle_text } else { without_rangefinders(&vehicle_text) };
    std::fs::write(&vehicle, vehicle_text).unwrap();
    let text = merged_graph("sim.toml");
    assert!(text.contains("\"worlds/empty.toml\"") && text.contains("\"vehicles/quad_x.toml\""));
    let text = text
        .replace("\"worlds/empty.toml\"", &format!("\"{}\"", world.display()))
        .replace("\"vehicles/quad_x.toml\"", &format!("\"{}\"", vehicle.display()));
    let path = dir.join("graph.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// The vehicle file without its `[sensors.rangefinder_*]` tables.
fn without_rangefinders(text: &str) -> String {
    let mut out = String::new();
    let mut skipping = false;
    for line in text.lines() {
        if line.starts_with('[') {
            skipping = line.starts_with("[sensors.rangefinder_");
        }
        if !skipping {
            out.push_str(line);
            out.push('\n');
        }
    }
    out
}

fn fly(name: &str, graph: &Path, plan: &Path) -> Value {
    let report =
        run_for_report(name, graph, &["--auto", "--exit-on-land", "--mission", &plan.display().to_string()]);
    println!("{name}: mission {} | flight {}", report["mission"], report["flight"]);
    report
}

/// Both scenarios' mission, written into `dir` as `name`: take off to 10 m, fly 20 m north at
/// 10 m, land there.
fn north_and_land(dir: &Path, name: &str) -> PathBuf {
    let items = [
        Item::north(qgc_plan::TAKEOFF, 0.0, 10.0),
        Item::north(qgc_plan::WAYPOINT, 20.0, 10.0),
        Item::north(qgc_plan::LAND, 20.0, 0.0),
    ];
    qgc_plan::write(dir, name, &items)
}

/// A slab 2 m thick whose underside is 6 m above home, 8 m square, centred over home: take off
/// to 10 m, fly 20 m north at 10 m, land there.
const SLAB: &str =
    "[[obstacles]]\nkind = \"box\"\ncenter_ned_m = [0.0, 0.0, -7.0]\nsize_m = [8.0, 8.0, 2.0]\n";

#[test]
fn a_takeoff_under_a_slab_stops_below_it_and_the_mission_climbs_once_clear() {
    let dir = scratch("vertical", "slab");
    let plan = north_and_land(&dir, "slab.plan");
    let with = fly("slab, rangefinders", &graph(&dir, SLAB, true), &plan);
    assert_eq!(collisions(&with), 0, "{with}");
    assert_eq!(with["flight"]["landed"], true);
    assert_eq!(with["mission"]["completed"], true);
    let clearance = clearance_m(&with);
    assert!(clearance > 1.0, "least clearance {clearance} m under the slab");
    let landed = with["flight"]["landing_distance_from_home_m"].as_f64().unwrap();
    assert!((landed - 20.0).abs() < 1.5, "landed {landed} m from home");
    let without = fly("slab, no rangefinders", &graph(&dir, SLAB, false), &plan);
    assert!(collisions(&without) > 0, "{without}");
}

/// A building 4 m high, 6 m square, centred 20 m north: take off to 10 m, fly there, land.
const ROOF: &str =
    "[[obstacles]]\nkind = \"box\"\ncenter_ned_m = [20.0, 0.0, -2.0]\nsize_m = [6.0, 6.0, 4.0]\n";

#[test]
fn a_landing_onto_a_roof_moves_back_off_it_and_lands_beside_it() {
    let dir = scratch("vertical", "roof");
    let plan = north_and_land(&dir, "roof.plan");
    let with = fly("roof, rangefinders", &graph(&dir, ROOF, true), &plan);
    assert_eq!(collisions(&with), 0, "{with}");
    assert_eq!(with["flight"]["landed"], true);
    let landed = with["flight"]["landing_distance_from_home_m"].as_f64().unwrap();
    // The roof spans 17–23 m north; moving back south it lands short of it.
    assert!(landed < 16.0, "landed {landed} m from home");
    let without = fly("roof, no rangefinders", &graph(&dir, ROOF, false), &plan);
    let on_roof = without["flight"]["landing_distance_from_home_m"].as_f64().unwrap();
    assert!(collisions(&without) > 0 || (17.0..23.0).contains(&on_roof), "{without}");
}
