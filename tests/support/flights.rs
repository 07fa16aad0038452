//! What the closed-loop flight tests share: the repository, scratch directories, the graph of
//! `config/sim-forest.toml` made runnable from anywhere with another world, and a lockstep run
//! of the `kestrel` binary whose `--report` JSON is the verdict.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

/// The repository's root.
pub fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A scratch directory of this test process, `kestrel-{prefix}-{pid}-{name}` under the system's
/// temporary directory.
pub fn scratch(prefix: &str, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kestrel-{prefix}-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `config/{file}`'s graph with its bases merged in, its MAVLink link on an ephemeral local port
/// (tests run in parallel, and a flight needs no ground station).
pub fn merged_graph(file: &str) -> String {
    let text = kestrel::LoadedConfig::load(&repo().join("config").join(file)).unwrap().merged_toml().unwrap();
    let link = "[actors.link]\ntype = \"link\"\n";
    assert!(text.contains(link), "{file} has a link");
    text.replace(
        link,
        &format!("{link}params.endpoints = [{{ type = \"udp_in\", bind = \"127.0.0.1:0\" }}]\n"),
    )
}

/// Takes the sockets off every link of `config`, for an in-process run beside other tests: the
/// default config's fixed UDP ports (18570, 14580) would be taken by whichever test binds them
/// first. The links keep their graph side.
pub fn without_link_sockets(config: &mut kestrel::LoadedConfig) {
    for link in config.graph.actors.values_mut().filter(|d| d.kind.get_ref() == "link") {
        let params =
            link.params.get_or_insert_with(|| toml::Spanned::new(0..0, toml::Table::new())).get_mut();
        params.insert("endpoints".into(), toml::Value::Array(Vec::new()));
    }
}

/// The text of `config/sim-forest.toml` (see [`merged_graph`]) flying `world` (a path), with
/// its relative paths made absolute.
pub fn sim_forest_graph(world: &Path) -> String {
    let config_dir = repo().join("config");
    let text = merged_graph("sim-forest.toml")
        .replace("worlds/forest.toml", &world.display().to_string())
        .replace("\"vehicles/", &format!("\"{}/vehicles/", config_dir.display()));
    assert!(!text.contains("\"worlds/forest.toml"), "the world was swapped");
    text
}

/// Runs `kestrel run --speedup 0 --quiet --config CONFIG ARGS… --report` from the repository
/// and returns the report. `name` labels a failure.
pub fn run_for_report(name: &str, config: &Path, args: &[&str]) -> Value {
    let report = config.with_file_name("report.json");
    let out = Command::new(env!("CARGO_BIN_EXE_kestrel"))
        .current_dir(repo())
        .env_remove("RUST_LOG")
        .args(["run", "--speedup", "0", "--quiet", "--config"])
        .arg(config)
        .args(args)
        .arg("--report")
        .arg(&report)
        .output()
        .unwrap();
    assert!(out.status.success(), "{name}: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap()
}

/// The number of collisions the report counts.
pub fn collisions(report: &Value) -> u64 {
    report["flight"]["collisions"].as_u64().expect("collisions")
}

/// The smallest clearance to any obstacle (m).
pub fn clearance_m(report: &Value) -> f64 {
    report["flight"]["min_clearance_m"].as_f64().expect("min_clearance_m")
}
