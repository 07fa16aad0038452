//! One obstacle-avoidance flight in lockstep, as tests/flight_avoidance.rs flies the thesis's
//! tests (§4.2.3): `config/sim-forest.toml` in another world, the report JSON the verdict. Shared
//! with tests/zenoh_split.rs, which flies the same worlds single-process beside the split.

use std::path::Path;

use serde_json::Value;

use super::flights::{run_for_report, scratch, sim_forest_graph};

/// Flies `mission` in `world` for at most `duration_s` (ending early on landing), prints its
/// `figure:` line and returns the flight report.
pub fn fly(name: &str, world: &Path, mission: &str, duration_s: u32) -> Value {
    let dir = scratch("avoid", name);
    let config = dir.join("graph.toml");
    std::fs::write(&config, sim_forest_graph(world)).unwrap();
    let duration = duration_s.to_string();
    let value = run_for_report(
        name,
        &config,
        &["--auto", "--exit-on-land", "--mission", mission, "--duration", &duration],
    );
    let _ = std::fs::remove_dir_all(&dir);
    let (flight, avoidance) = (&value["flight"], &value["avoidance"]);
    println!(
        "figure: {name}: completed {}, collisions {}, min clearance {:.2} m, {:.1} s, path {:.1} m for {:.1} m straight, {} (host wall clock), perception real-time factor {:.2}x, speed capped {:.1} s (lowest cap {:.2} m/s)",
        value["mission"]["completed"],
        flight["collisions"],
        flight["min_clearance_m"].as_f64().unwrap_or(f64::NAN),
        flight["duration_s"].as_f64().unwrap_or(f64::NAN),
        flight["path_length_m"].as_f64().unwrap_or(f64::NAN),
        flight["straight_line_m"].as_f64().unwrap_or(f64::NAN),
        frame_to_setpoint(&value),
        avoidance["realtime_factor"].as_f64().unwrap_or(f64::NAN),
        avoidance["speed_capped_s"].as_f64().unwrap_or(f64::NAN),
        avoidance["lowest_speed_cap_m_s"].as_f64().unwrap_or(f64::NAN),
    );
    assert!(
        avoidance["realtime_factor"].as_f64().is_some_and(|r| r > 0.0),
        "{name}: the report gives the perception real-time factor: {value:#}"
    );
    value
}

/// `frame→setpoint p50 … ms p95 … ms (N frames)` of a report's avoidance section.
pub fn frame_to_setpoint(report: &Value) -> String {
    let avoidance = &report["avoidance"];
    format!(
        "frame→setpoint p50 {:.1} ms p95 {:.1} ms ({} frames)",
        avoidance["frame_to_setpoint_p50_ms"].as_f64().unwrap_or(f64::NAN),
        avoidance["frame_to_setpoint_p95_ms"].as_f64().unwrap_or(f64::NAN),
        avoidance["samples"],
    )
}
