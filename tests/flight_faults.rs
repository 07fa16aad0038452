//! Closed-loop lockstep flights of the default graph (`config/sim.toml`) with faults injected
//! from the world file's `[[faults]]`: the process does not crash, the
//! lockstep clock runs on, and the vehicle stays controlled. What the commander did (the
//! report's `failsafes`) is printed and pinned, so a change of failsafe policy shows here; the
//! policy itself is another task's.

use std::path::{Path, PathBuf};
use std::process::Command;

use kestrel::recorder::LogReader;
use kestrel_proto::messages::ActuatorOutputs;
use serde_json::Value;

mod support;
use qgc_plan::Item;
use support::qgc_plan;

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A scratch directory of this test process for flight `name`.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kestrel-fault-flights-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes `empty.toml` plus `faults` as the world and `config/sim.toml` (its bases merged in) flying it (absolute
/// paths, the MAVLink link on an ephemeral local port) into `dir`; returns the graph's path.
fn graph_with_faults(dir: &Path, faults: &str) -> PathBuf {
    let config_dir = repo().join("config");
    let world = dir.join("world.toml");
    let empty = std::fs::read_to_string(config_dir.join("worlds/empty.toml")).unwrap();
    std::fs::write(&world, format!("{empty}\n{faults}")).unwrap();
    let stock = kestrel::LoadedConfig::load(&config_dir.join("sim.toml")).unwrap();
    let text = stock.merged_toml().unwrap();
    let link = "[actors.link]\ntype = \"link\"\n";
    assert!(text.contains(link) && text.contains("\"worlds/empty.toml\""), "the stock graph changed");
    let text = text
        .replace(
            link,
            &format!("{link}params.endpoints = [{{ type = \"udp_in\", bind = \"127.0.0.1:0\" }}]\n"),
        )
        .replace("\"worlds/empty.toml\"", &format!("\"{}\"", world.display()))
        .replace("\"vehicles/", &format!("\"{}/vehicles/", config_dir.display()));
    let graph = dir.join("graph.toml");
    std::fs::write(&graph, text).unwrap();
    graph
}

/// A QGroundControl plan: take off to 10 m at home, hold there `hold_s`, land at home.
fn hover_plan(dir: &Path, hold_s: f64) -> PathBuf {
    let hold = Item { hold_s, ..Item::north(qgc_plan::WAYPOINT, 0.0, 10.0) };
    let items = [Item::north(qgc_plan::TAKEOFF, 0.0, 10.0), hold, Item::north(qgc_plan::LAND, 0.0, 0.0)];
    qgc_plan::write(dir, "hover.plan", &items)
}

/// Flies `mission` on `graph` with `kestrel run --speedup 0 --auto --exit-on-land`, recording
/// to `record` if given; returns the report. The run must end by itself, exit 0.
fn fly(name: &str, graph: &Path, mission: &Path, record: Option<&Path>) -> Value {
    let report = graph.with_file_name("report.json");
    let mut command = Command::new(env!("CARGO_BIN_EXE_kestrel"));
    command
        .current_dir(repo())
        .env_remove("RUST_LOG")
        .args(["run", "--speedup", "0", "--quiet", "--auto", "--exit-on-land", "--config"])
        .arg(graph)
        .arg("--mission")
        .arg(mission)
        .arg("--report")
        .arg(&report);
    if let Some(record) = record {
        command.arg("--record").arg(record);
    }
    let out = command.output().unwrap();
    assert!(out.status.success(), "{name}: {}", String::from_utf8_lossy(&out.stderr));
    let report: Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    println!(
        "{name}: mission {} | flight {} | estimator {} | failsafes {} | faults {}",
        report["mission"], report["flight"], report["estimator"], report["failsafes"], report["faults"]
    );
    report
}

/// The `(t_s, phase, kind)` of each fault start and end in the report.
fn fault_events(report: &Value) -> Vec<(f64, String, String)> {
    report["faults"]
        .as_array()
        .expect("faults")
        .iter()
        .map(|f| {
            let s = |k: &str| f[k].as_str().expect(k).to_owned();
            (f["t_s"].as_f64().expect("t_s"), s("phase"), s("kind"))
        })
        .collect()
}

/// The `(t_s, cause, action)` of each failsafe in the report.
fn failsafes(report: &Value) -> Vec<(f64, String, String)> {
    report["failsafes"]
        .as_array()
        .expect("failsafes")
        .iter()
        .map(|f| {
            let s = |k: &str| f[k].as_str().expect(k).to_owned();
            (f["t_s"].as_f64().expect("t_s"), s("cause"), s("action"))
        })
        .collect()
}

/// Ended on the ground, intact, having hit nothing.
fn assert_landed_intact(name: &str, report: &Value) {
    let flight = &report["flight"];
    assert_eq!(flight["crashed"], false, "{name}: crashed");
    assert_eq!(flight["landed"], true, "{name}: did not land");
    assert_eq!(flight["collisions"], 0, "{name}: collided");
}

fn f64_at(report: &Value, section: &str, field: &str) -> f64 {
    report[section][field].as_f64().unwrap_or_else(|| panic!("{section}.{field} in {report}"))
}

#[test]
fn gps_lost_for_30_s_mid_patrol_lands_without_position_intact() {
    let dir = scratch("gps-off");
    let graph = graph_with_faults(&dir, "[[faults]]\nat_s = 100.0\nfor_s = 30.0\nkind = \"gps_off\"\n");
    let report = fly("gps_off", &graph, &repo().join("config/missions/patrol.plan"), None);
    let started = |kind: &str| (100.0, "started".to_owned(), kind.to_owned());
    let events = fault_events(&report);
    // The run ends on landing: a landing done within the 30 s sees no end of the fault.
    let ended = (130.0, "ended".to_owned(), "gps_off".to_owned());
    let duration_s = f64_at(&report, "flight", "duration_s");
    let expected =
        if duration_s > 130.0 { vec![started("gps_off"), ended] } else { vec![started("gps_off")] };
    assert_eq!(events, expected, "a flight of {duration_s} s");
    assert_landed_intact("gps_off", &report);
    // What the commander does today: the estimator reports itself unhealthy once its position
    // times out (5 s) and the commander lands where it is (no position to return with).
    let fired = failsafes(&report);
    let (t_s, cause, action) = fired.first().expect("a failsafe fired").clone();
    assert!((100.0..110.0).contains(&t_s), "detected after {} s", t_s - 100.0);
    assert_eq!((cause.as_str(), action.as_str()), ("estimator_unhealthy", "land"), "{fired:?}");
    assert_eq!(report["mission"]["completed"], false, "the failsafe ends the mission");
    // Dead reckoning drifts, but not out of the field.
    let worst_m = f64_at(&report, "estimator", "max_horizontal_m");
    assert!(worst_m > 1.0 && worst_m < 100.0, "worst horizontal error {worst_m} m");
    println!(
        "gps_off: failsafe {cause}/{action} {:.2} s after the loss; worst horizontal error {worst_m:.1} m; \
         landed {:.1} m from home",
        t_s - 100.0,
        f64_at(&report, "flight", "landing_distance_from_home_m")
    );
}

#[test]
fn motor_1_weakened_to_70_percent_in_hover_stays_up_and_finishes() {
    let dir = scratch("motor-weak");
    let graph =
        graph_with_faults(&dir, "[[faults]]\nat_s = 20.0\nkind = \"motor_weak\"\nmotor = 1\nthrust = 0.7\n");
    let log = dir.join("flight.mcap");
    let report = fly("motor_weak", &graph, &hover_plan(&dir, 60.0), Some(&log));
    assert_eq!(fault_events(&report), [(20.0, "started".to_owned(), "motor_weak".to_owned())]);
    assert_landed_intact("motor_weak", &report);
    assert!(failsafes(&report).is_empty(), "{}", report["failsafes"]);
    assert_eq!(report["mission"]["completed"], true);
    let tracking_m = f64_at(&report, "flight", "tracking_error_max_m");
    assert!(tracking_m < 2.0, "strayed {tracking_m} m from the legs");
    // The controller takes up the weak motor: in the hold after the fault, motor 1 is commanded
    // about 1/0.7 of what the others are (thrust is linear in the command).
    let outputs = LogReader::open(&log).unwrap().read::<ActuatorOutputs>("actuator_outputs").unwrap();
    let hold: Vec<&ActuatorOutputs> = outputs
        .iter()
        .map(|r| &r.message)
        .filter(|o| o.armed && (40.0..70.0).contains(&o.time.as_secs_f64()))
        .collect();
    assert!(hold.len() > 10_000, "{} outputs in the hold", hold.len());
    let mean = |m: usize| hold.iter().map(|o| o.motors[m]).sum::<f64>() / hold.len() as f64;
    let ratio = mean(0) / ((mean(1) + mean(2) + mean(3)) / 3.0);
    println!(
        "motor_weak: motor commands in the hold {:.3} {:.3} {:.3} {:.3}, motor 1 / others = {ratio:.3}; \
         tracking error max {tracking_m:.2} m",
        mean(0),
        mean(1),
        mean(2),
        mean(3)
    );
    assert!(ratio > 1.2 && ratio < 1.6, "motor 1 / others = {ratio}");
}

#[test]
fn imu_stopping_for_half_a_second_in_hover_does_not_stall_the_lockstep_clock_and_the_second_imu_takes_over() {
    let dir = scratch("imu-stop");
    let graph = graph_with_faults(&dir, "[[faults]]\nat_s = 30.0\nfor_s = 0.5\nkind = \"imu_stop\"\n");
    let report = fly("imu_stop", &graph, &hover_plan(&dir, 60.0), None);
    assert_eq!(
        fault_events(&report),
        [
            (30.0, "started".to_owned(), "imu_stop".to_owned()),
            (30.5, "ended".to_owned(), "imu_stop".to_owned())
        ]
    );
    // The run went on past the stop and ended itself on landing.
    assert!(f64_at(&report, "flight", "duration_s") > 31.0);
    assert_landed_intact("imu_stop", &report);
    // The simulated board has two IMUs (config/vehicles/quad_x.toml): the estimator moves to the
    // second within its 20 ms timeout, so the state never goes stale and no failsafe fires.
    let fired = failsafes(&report);
    assert!(fired.is_empty(), "{fired:?}");
    let switched: Vec<f64> = report["estimator_events"]
        .as_array()
        .expect("estimator_events")
        .iter()
        .filter(|e| e["event"] == "imu_switched")
        .map(|e| e["t_s"].as_f64().expect("t_s"))
        .collect();
    assert!(switched.len() == 1 && (30.0..30.1).contains(&switched[0]), "{switched:?}");
    println!("imu_stop: the estimator switched IMU {:.3} s after the stop", switched[0] - 30.0);
}

#[test]
fn the_estimator_panicking_once_in_hover_is_restarted_and_the_vehicle_lands() {
    let dir = scratch("estimator-panic");
    let graph = graph_with_faults(
        &dir,
        "[[faults]]\nat_s = 30.0\nfor_s = 0.01\nkind = \"actor_panic\"\nactor = \"estimator\"\n",
    );
    let report = fly("actor_panic", &graph, &hover_plan(&dir, 60.0), None);
    assert_eq!(fault_events(&report)[0], (30.0, "started".to_owned(), "actor_panic".to_owned()));
    assert_landed_intact("actor_panic", &report);
    let fired = failsafes(&report);
    let (t_s, cause, action) = fired.first().expect("a failsafe fired").clone();
    assert!((30.0..30.1).contains(&t_s), "{fired:?}");
    assert_eq!((cause.as_str(), action.as_str()), ("critical_actor_failed", "land"), "{fired:?}");
    // Restarted, it aligns again and flies the landing on its own estimate.
    assert!(f64_at(&report, "estimator", "max_horizontal_m") < 3.0);
    println!(
        "actor_panic: failsafe {cause}/{action} {:.3} s after the panic; landed {:.2} m from home",
        t_s - 30.0,
        f64_at(&report, "flight", "landing_distance_from_home_m")
    );
}

/// The estimator panics from 20 s on, for good (the supervisor gives up on it), while the
/// vehicle flies north at 12 m: the controller's backup attitude takes over, the commander
/// announces it and lands, level, on the backup's height and climb rate, drifting (no
/// horizontal position), and the report names the backup as the source flown.
#[test]
fn the_estimator_failing_for_good_in_forward_flight_lands_level_on_the_backup_attitude() {
    let dir = scratch("estimator-gone");
    let graph =
        graph_with_faults(&dir, "[[faults]]\nat_s = 20.0\nkind = \"actor_panic\"\nactor = \"estimator\"\n");
    let report = fly("estimator_gone", &graph, &qgc_plan::leg(&dir, 0.0, 100.0, 12.0), None);
    assert_landed_intact("estimator_gone", &report);
    let fired = failsafes(&report);
    assert!(fired.iter().all(|(_, _, action)| action == "land"), "{fired:?}");
    assert!(fired.iter().any(|(t, cause, _)| cause == "critical_actor_failed" && *t >= 20.0), "{fired:?}");
    let source = &report["attitude_source"];
    assert_eq!(source["flown"], "backup", "{source}");
    let switched = source["switches"][0]["t_s"].as_f64().expect("a switch");
    assert_eq!(source["switches"][0]["to"], "backup", "{source}");
    // The loop's own stale limit (nav_timeout_s, 50 ms) after the last state before the panic.
    assert!((20.0..20.2).contains(&switched), "switched at {switched} s");
    let notices = report["notices"].as_array().expect("notices");
    assert!(
        notices.iter().any(|n| n["text"] == "EKF failed: backup attitude"),
        "the switch announced: {notices:?}"
    );
    let rms_deg = f64_at(&report, "attitude_source", "backup_rms_roll_pitch_deg");
    let worst_deg = f64_at(&report, "attitude_source", "backup_max_roll_pitch_deg");
    // The accelerometer reads the drag of the slowing vehicle as tilt: the error peaks near
    // √(k·c)·v/g (k = ATT_W_ACC 0.2, drag c ≈ 0.1/s, v ≈ 5 m/s), about 4°, and the vehicle,
    // levelled on it, drifts on (2.3° RMS, 4.0° worst, 28 m of drift as flown here).
    assert!(rms_deg < 3.0 && worst_deg < 6.0, "backup error vs truth: rms {rms_deg}°, worst {worst_deg}°");
    let touchdown = &report["flight"]["touchdown"];
    let speed = touchdown["speed_down_m_s"].as_f64().expect("touchdown speed");
    let tilt = touchdown["tilt_deg"].as_f64().expect("touchdown tilt");
    // LAND's slow rate near the ground is 0.6 m/s (`land_slow_m_s`); the ground's crash limits
    // are 3 m/s and 60°.
    assert!(speed < 1.0 && tilt < 10.0, "touchdown {touchdown}");
    println!(
        "estimator_gone: backup from {switched:.3} s, {:.1} s on it; roll/pitch error vs truth rms {rms_deg:.2}°, \
         worst {worst_deg:.2}°, yaw rms {:.2}°; touchdown {speed:.2} m/s at {tilt:.1}°, {:.1} m from home; \
         max tilt {:.1}°; failsafes {fired:?}",
        f64_at(&report, "attitude_source", "backup_s"),
        f64_at(&report, "attitude_source", "backup_rms_yaw_deg"),
        f64_at(&report, "flight", "landing_distance_from_home_m"),
        f64_at(&report, "flight", "max_tilt_deg"),
    );
}

#[test]
fn an_actor_panic_naming_no_actor_of_the_graph_is_refused_at_start_up() {
    let dir = scratch("panic-nobody");
    let graph =
        graph_with_faults(&dir, "[[faults]]\nat_s = 30.0\nkind = \"actor_panic\"\nactor = \"stereo\"\n");
    let out = Command::new(env!("CARGO_BIN_EXE_kestrel"))
        .current_dir(repo())
        .env_remove("RUST_LOG")
        .args(["run", "--speedup", "0", "--quiet", "--config"])
        .arg(&graph)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    let world = dir.join("world.toml");
    let line = std::fs::read_to_string(&world).unwrap().lines().position(|l| l == "[[faults]]").unwrap() + 1;
    assert!(
        stderr.contains(&format!(
            "{}:{line}: `faults[0].actor` \"stereo\" is not an actor of the graph",
            world.display()
        )),
        "{stderr}"
    );
}
