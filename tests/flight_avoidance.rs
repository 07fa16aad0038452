//! The thesis's obstacle-avoidance flight tests (§4.2.3) and a forest, flown closed loop in
//! lockstep by the `kestrel` binary: simulated stereo camera → stereo → fuzzy avoider →
//! commander → controller → simulator. Each flight's `--report` JSON is the verdict, and the
//! flights at 5 m/s check their rows of docs/src/results/avoidance.md against it
//! ([`avoidance_page`]; `KESTREL_UPDATE_DOCS=1` rewrites them).
//!
//! The graph is `config/sim-forest.toml` with the world swapped and the MAVLink link on an
//! ephemeral local port (tests run in parallel, and a flight needs no ground station).

mod support;
use support::{avoidance_flight, avoidance_page, flights, forest_seeds, qgc_plan};

use std::path::PathBuf;

use avoidance_flight::fly;
use avoidance_page::mission_row;
use flights::{clearance_m, collisions, repo, run_for_report, scratch, sim_forest_graph};
use forest_seeds::{Flight, HOME_LANDING_M, fly_seeds, seed_rows, set, template};
use serde_json::Value;

fn world(name: &str) -> PathBuf {
    repo().join("config/worlds").join(name)
}

fn completed(report: &Value) -> bool {
    report["mission"]["completed"].as_bool().expect("mission.completed")
}

#[test]
fn thesis_test_1_a_large_tree_across_the_leg_is_flown_around_and_the_mission_completes() {
    let report = fly("tree", &world("tree.toml"), "config/missions/leg-40m.plan", 90);
    assert_eq!(collisions(&report), 0, "{report:#}");
    assert!(clearance_m(&report) > 0.3, "{report:#}");
    assert!(completed(&report), "{report:#}");
}

#[test]
fn rtl_flies_around_a_tree_taller_than_its_altitude() {
    // The tree of tree.toml, 25 m tall, on the way home: RTL climbs to 15 m at 40 m north and
    // returns straight at it (blind, it flew into the tree).
    let dir = scratch("avoid-rtl", "tall-tree");
    let stock = std::fs::read_to_string(world("tree.toml")).unwrap();
    let tall = stock.replace("height_m = 14.0", "height_m = 25.0");
    assert_ne!(tall, stock, "the tree was raised");
    let world = dir.join("tall-tree.toml");
    std::fs::write(&world, tall).unwrap();
    let plan = qgc_plan::write(
        &dir,
        "out-and-rtl.plan",
        &[
            qgc_plan::Item::north(qgc_plan::TAKEOFF, 0.0, 6.0),
            qgc_plan::Item::north(qgc_plan::WAYPOINT, 40.0, 6.0),
            qgc_plan::Item::north(qgc_plan::RETURN_TO_LAUNCH, 0.0, 0.0),
        ],
    );
    let report = fly("rtl-tall-tree", &world, &plan.display().to_string(), 150);
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(collisions(&report), 0, "{report:#}");
    assert!(clearance_m(&report) > 0.3, "{report:#}");
    assert_eq!(report["flight"]["landed"], Value::Bool(true), "{report:#}");
    let from_home = report["flight"]["landing_distance_from_home_m"].as_f64().expect("landing distance");
    assert!(from_home < HOME_LANDING_M, "landed {from_home} m from home: {report:#}");
    avoidance_page::check(&[mission_row("RTL past a 25 m tree (RTL at 15 m)", "AUTO, RTL", "", &report)]);
}

#[test]
fn the_same_lockstep_flight_flown_twice_is_the_same_flight() {
    // The stereo pipeline runs on the blocking pool while the simulation goes on, and how fast
    // it finishes depends on the host; in lockstep that must not change the flight. Before the
    // stereo actor blocked for a late pipeline, three idle runs of one RTL flight ended 83.4,
    // 82.0 and 150 s in. Everything in the report's flight and mission sections is simulated.
    let first = fly("tree-again-1", &world("tree.toml"), "config/missions/leg-40m.plan", 60);
    let second = fly("tree-again-2", &world("tree.toml"), "config/missions/leg-40m.plan", 60);
    for section in ["flight", "mission"] {
        assert_eq!(first[section], second[section], "{section}: {first:#} against {second:#}");
    }
}

#[test]
fn thesis_test_2_a_textured_wall_across_the_leg_is_avoided() {
    let report = fly("wall-textured", &world("wall-textured.toml"), "config/missions/leg-40m.plan", 90);
    assert_eq!(collisions(&report), 0, "{report:#}");
    assert!(clearance_m(&report) > 0.3, "{report:#}");
    assert!(completed(&report), "{report:#}");
}

#[test]
fn thesis_test_2_a_textureless_wall_stops_the_vehicle_short_where_the_thesis_crashed() {
    // The mission cannot complete (no way is seen through or around a wall without texture);
    // the vehicle must stop short of it and stay there.
    let report = fly("wall-plain", &world("wall-plain.toml"), "config/missions/leg-40m.plan", 40);
    assert_eq!(collisions(&report), 0, "{report:#}");
    assert!(clearance_m(&report) > 1.0, "{report:#}");
    assert!(!completed(&report), "{report:#}");
}

#[test]
fn a_textured_wall_across_the_leg_at_5_m_s_is_flown_around() {
    let dir = scratch("avoid", "wall-textured-5ms-plan");
    let plan = qgc_plan::leg(&dir, 0.0, 40.0, 6.0);
    let report = fly("wall-textured-5ms", &world("wall-textured.toml"), &plan.display().to_string(), 90);
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(collisions(&report), 0, "{report:#}");
    assert!(clearance_m(&report) > 0.3, "{report:#}");
    assert!(completed(&report), "{report:#}");
    avoidance_page::check(&[mission_row("textured wall", "AUTO", "flown around", &report)]);
}

#[test]
fn a_textureless_wall_at_5_m_s_stops_the_vehicle_short() {
    let dir = scratch("avoid", "wall-plain-5ms-plan");
    let plan = qgc_plan::leg(&dir, 0.0, 40.0, 6.0);
    let report = fly("wall-plain-5ms", &world("wall-plain.toml"), &plan.display().to_string(), 40);
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(collisions(&report), 0, "{report:#}");
    assert!(clearance_m(&report) > 1.0, "{report:#}");
    assert!(!completed(&report), "{report:#}");
    avoidance_page::check(&[mission_row("plain wall", "AUTO", "stopped short", &report)]);
}

/// Flies the 40 m leg at 5 m/s past the 10 cm pole of `config/worlds/pole.toml`, with
/// `backdrop` (more `[[obstacles]]`) added to the world.
fn fly_past_the_pole(name: &str, backdrop: &str) -> Value {
    let dir = scratch("avoid", name);
    let stock = std::fs::read_to_string(world("pole.toml")).unwrap();
    let path = dir.join("pole.toml");
    std::fs::write(&path, format!("{stock}{backdrop}")).unwrap();
    let plan = qgc_plan::leg(&dir, 0.0, 40.0, 6.0);
    let report = fly(name, &path, &plan.display().to_string(), 90);
    let _ = std::fs::remove_dir_all(&dir);
    report
}

#[test]
fn a_10_cm_pole_on_the_leg_at_5_m_s_is_flown_around() {
    let report = fly_past_the_pole("pole-5ms", "");
    assert_eq!(collisions(&report), 0, "{report:#}");
    assert!(clearance_m(&report) > 0.3, "{report:#}");
    assert!(completed(&report), "{report:#}");
    avoidance_page::check(&[mission_row("10 cm pole, open sky behind", "AUTO", "flown around", &report)]);
}

#[test]
fn a_10_cm_pole_before_a_textured_wall_at_5_m_s_is_flown_around() {
    // The wall stands 15 m beyond the leg's end: behind the pole it gives the centre region
    // depths everywhere, so the untextured view's 4 m no longer stands in for the pole.
    let wall = "\n[[obstacles]]\nkind = \"wall\"\nfrom_ne_m = [55.0, -20.0]\nto_ne_m = [55.0, 20.0]\n\
                height_m = 25.0\nthickness_m = 0.3\ntextured = true\n";
    let report = fly_past_the_pole("pole-backdrop-5ms", wall);
    assert_eq!(collisions(&report), 0, "{report:#}");
    assert!(clearance_m(&report) > 0.3, "{report:#}");
    assert!(completed(&report), "{report:#}");
    avoidance_page::check(&[mission_row(
        "10 cm pole, textured wall 35 m behind it",
        "AUTO",
        "flown around",
        &report,
    )]);
}

#[test]
fn the_descent_after_a_climb_over_the_forest_keeps_to_what_the_camera_sees() {
    // Forest seed 9 with AVOID_SIDE_MAX at 3 m: boxed in among the trunks, the vehicle climbs
    // over them, then comes back down to the leg's 5 m flying on. Descending at the leg's 2 m/s
    // at 2.5 m/s forward it met a trunk below the camera's centre band, which is all the speed
    // cap reads (1 collision, least clearance 0.19 m, with DESCENT_SLOPE lifted to 1e9 on
    // 81baa64); no steeper than the commander's DESCENT_SLOPE, it stays clear.
    let dir = scratch("avoid-descent", "forest-9");
    let world = dir.join("forest-9.toml");
    std::fs::write(&world, set(&template("forest.toml"), "seed", "9")).unwrap();
    let plan = qgc_plan::leg(&dir, 0.0, 100.0, 5.0);
    let (stock, side_max) = ("max_speed_m_s = 5.0\n", "max_speed_m_s = 5.0\nsidestep_max_m = 3.0\n");
    let graph = sim_forest_graph(&world);
    assert!(graph.contains(stock), "the avoider's parameters moved");
    let config = dir.join("graph.toml");
    std::fs::write(&config, graph.replace(stock, side_max)).unwrap();
    let plan = plan.display().to_string();
    let report = run_for_report(
        "descent",
        &config,
        &["--auto", "--exit-on-land", "--mission", &plan, "--duration", "150"],
    );
    let _ = std::fs::remove_dir_all(&dir);
    println!(
        "figure: forest seed 9, AVOID_SIDE_MAX 3 m: completed {}, collisions {}, min clearance {:.2} m, {:.1} s",
        report["mission"]["completed"],
        collisions(&report),
        clearance_m(&report),
        report["flight"]["duration_s"].as_f64().unwrap_or(f64::NAN)
    );
    assert_eq!(collisions(&report), 0, "{report:#}");
    assert!(completed(&report), "{report:#}");
}

#[test]
fn a_forest_of_24_trees_on_a_100_m_leg_at_5_m_s_is_flown_through_without_collision_for_nine_of_ten_seeds() {
    let world = template("forest.toml");
    let outcomes = fly_seeds("forest", &(1..=10).collect::<Vec<u64>>(), 150, |dir, seed| {
        let path = dir.join(format!("forest-{seed}.toml"));
        std::fs::write(&path, set(&world, "seed", &seed.to_string())).unwrap();
        Flight {
            label: String::new(),
            world: path,
            plan: qgc_plan::leg(dir, 0.0, 100.0, 5.0),
            lands_home: false,
        }
    });
    let good = outcomes.iter().filter(|o| o.clean).count();
    assert!(good >= 9, "{good} of 10 seeds completed without a collision: {outcomes:?}");
    avoidance_page::check(&seed_rows("forest seed", &outcomes));
}
