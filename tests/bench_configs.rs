//! Every graph in `config/` goes through the graph builder: the hardware-less ones build and
//! run briefly, the Navio2 ones stop at start-up naming each device this machine lacks.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use kestrel::{LoadedConfig, Registry, RunError, RunOptions, run};

/// Devices and driver files the hardware graphs open, per config.
const HARDWARE: [(&str, &[&str]); 2] = [
    (
        "navio2.toml",
        &[
            "/dev/spidev0.1",
            "/dev/i2c-1",
            "/dev/ttyAMA0",
            "/sys/kernel/rcio/rcin/ch0",
            "/sys/class/pwm/pwmchip0",
        ],
    ),
    ("bench-sensors.toml", &["/dev/spidev0.1", "/dev/i2c-1", "/dev/ttyAMA0", "/sys/kernel/rcio/rcin/ch0"]),
];

/// A topic each hardware-less graph must have published on within its short run (the link
/// alone has no source in the graph: it must build and run).
const PUBLISHES: [(&str, Option<&str>); 6] = [
    ("sim.toml", Some("nav_state")),
    ("bench-estimator-replay.toml", Some("nav_state")),
    ("perception-sim.toml", Some("depth_grid")),
    ("sim-forest.toml", Some("depth_grid")),
    ("bench-stereo-files.toml", Some("avoidance_command")),
    ("bench-link.toml", None),
];

fn configs() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("config");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("config dir")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    files
}

fn file_name(path: &Path) -> &str {
    path.file_name().and_then(|n| n.to_str()).expect("utf-8 name")
}

#[test]
fn every_config_builds_or_names_the_hardware_it_lacks() {
    let files = configs();
    for (name, _) in HARDWARE.iter().chain(&[
        ("bench-link.toml", &[][..]),
        ("bench-stereo-files.toml", &[][..]),
        ("bench-estimator-replay.toml", &[][..]),
    ]) {
        assert!(files.iter().any(|f| file_name(f) == *name), "config/{name} is missing");
    }
    for path in &files {
        let name = file_name(path);
        let config = LoadedConfig::load(path).unwrap_or_else(|e| panic!("{name} does not parse: {e}"));
        let options = RunOptions {
            duration: Some(Duration::from_millis(1500)),
            speedup: Some(0.0),
            ..RunOptions::default()
        };
        let outcome = run(&config, &Registry::standard(), options);
        match HARDWARE.iter().find(|(n, _)| *n == name) {
            Some((_, devices)) => {
                let Err(RunError::Config(errors)) = outcome else {
                    panic!("{name} started without its hardware");
                };
                let message = errors.iter().map(ToString::to_string).collect::<Vec<_>>().join("\n");
                for device in devices.iter().filter(|d| !Path::new(d).exists()) {
                    assert!(message.contains(device), "{name}: no error names {device}:\n{message}");
                }
            }
            None => {
                let report = outcome.unwrap_or_else(|e| panic!("{name} does not build: {e}"));
                let published =
                    |topic: &str| report.topics.iter().find(|(t, _, _)| t == topic).map_or(0, |(_, _, n)| *n);
                let (_, topic) = PUBLISHES
                    .iter()
                    .find(|(n, _)| *n == name)
                    .unwrap_or_else(|| panic!("add config/{name} to PUBLISHES with a topic it must publish"));
                if let Some(topic) = topic {
                    assert!(published(topic) > 0, "{name}: nothing on '{topic}'");
                }
            }
        }
    }
}

#[test]
fn kestrel_run_on_navio2_without_the_board_exits_naming_the_device() {
    let config = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/navio2.toml");
    let out = Command::new(env!("CARGO_BIN_EXE_kestrel"))
        .args(["run", "--config"])
        .arg(&config)
        .output()
        .expect("run kestrel");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "exit status {:?}", out.status);
    assert!(stderr.contains("/dev/spidev0.1"), "{stderr}");
}
