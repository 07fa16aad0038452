//! Every graph in `config/` goes through the graph builder: the hardware-less ones build and
//! run briefly, the Navio2 ones stop at start-up naming each device this machine lacks.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use kestrel::{LoadedConfig, Registry, RunError, RunOptions, run, unwired_parameters};

/// Devices and driver files the hardware graphs open, per config.
const HARDWARE: [(&str, &[&str]); 4] = [
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
    // The flight controller's UART and the stereo camera.
    ("companion-ardupilot.toml", &["/dev/ttyTHS1", "/dev/video0"]),
    ("companion-px4.toml", &["/dev/ttyTHS1", "/dev/video0"]),
];

/// A topic each hardware-less graph must have published on within its short run (the link
/// alone has no source in the graph: it must build and run).
const PUBLISHES: [(&str, Option<&str>); 9] = [
    ("sim.toml", Some("nav_state")),
    ("bench-estimator-replay.toml", Some("nav_state")),
    ("perception-sim.toml", Some("depth_grid")),
    ("sim-forest.toml", Some("depth_grid")),
    ("bench-stereo-files.toml", Some("avoidance_command")),
    ("bench-link.toml", None),
    ("fleet-sim.toml", Some("nav_state")),
    ("split-flight.toml", Some("nav_state")),
    // Its inputs come over Zenoh from split-flight.toml's process, which is not running.
    ("split-vision.toml", None),
];

/// The graphs with a Zenoh bridge: in a build without the `zenoh` feature they stop at start-up
/// saying so.
const ZENOH: [&str; 3] = ["fleet-sim.toml", "split-flight.toml", "split-vision.toml"];

fn configs_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("config")
}

/// Every graph in `config/` (the bases in `config/base/` are parts of graphs, not graphs).
fn configs() -> Vec<PathBuf> {
    let dir = configs_dir();
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
        if ZENOH.contains(&name) && !cfg!(feature = "zenoh") {
            let Err(RunError::Config(errors)) = outcome else { panic!("{name} started without its bridge") };
            let message = errors.iter().map(ToString::to_string).collect::<Vec<_>>().join("\n");
            assert!(message.contains("built without the Zenoh bridge"), "{name}: {message}");
            continue;
        }
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

#[test]
fn every_graph_routes_every_live_parameter_to_its_link() {
    for path in configs() {
        let name = file_name(&path);
        let config = LoadedConfig::load(&path).unwrap_or_else(|e| panic!("{name} does not parse: {e}"));
        let unwired = unwired_parameters(&config, &Registry::standard());
        assert!(unwired.is_empty(), "config/{name}:\n{}", unwired.join("\n"));
    }
    // The check sees a port left out: config/sim.toml without the estimator's parameter routes.
    let mut config = LoadedConfig::load(&configs_dir().join("sim.toml")).expect("config/sim.toml");
    let estimator =
        config.graph.actors.iter_mut().find(|(n, _)| n.get_ref() == "estimator").expect("estimator");
    estimator.1.inputs.retain(|port, _| port.get_ref() != "param_set");
    let unwired = unwired_parameters(&config, &Registry::standard());
    assert_eq!(unwired.len(), 1, "{unwired:?}");
    assert!(unwired[0].contains("'estimator'") && unwired[0].contains("param_set"), "{unwired:?}");
    let link = config.graph.actors.iter_mut().find(|(n, _)| n.get_ref() == "link").expect("link");
    link.1.inputs.retain(|port, _| port.get_ref() != "param_decl");
    let unwired = unwired_parameters(&config, &Registry::standard());
    for owner in ["estimator.param_decl", "controller.param_decl", "commander.param_decl"] {
        assert!(unwired.iter().any(|u| u.contains(owner)), "{owner} not in {unwired:?}");
    }
}

#[test]
fn composed_sim_toml_is_the_graph_it_was_written_out_in_full() {
    let composed = LoadedConfig::load(&configs_dir().join("sim.toml")).expect("config/sim.toml");
    let flat_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/graphs/sim-flat.toml");
    let flat: toml::Table =
        toml::from_str(&std::fs::read_to_string(flat_path).expect("fixture")).expect("toml");
    assert_eq!(composed.merged, flat, "merged:\n{}", composed.merged_toml().unwrap_or_default());
    // And what `--print-config` prints is that graph.
    let out = Command::new(env!("CARGO_BIN_EXE_kestrel"))
        .args(["run", "--print-config", "--config"])
        .arg(configs_dir().join("sim.toml"))
        .output()
        .expect("run kestrel");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let printed: toml::Table = toml::from_str(&String::from_utf8_lossy(&out.stdout)).expect("printed TOML");
    assert_eq!(printed, flat);
}

#[test]
fn an_error_in_a_composed_graph_names_the_file_that_spelled_the_key() {
    let dir = std::env::temp_dir().join(format!("kestrel-bench-configs-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let base = dir.join("base.toml");
    std::fs::write(
        &base,
        "[actors.a]\ntype = \"sim\"\n\n[actors.b]\ntype = \"sim\"\nrestart = { window_s = -1.0 }\n",
    )
    .expect("base");
    let child = dir.join("child.toml");
    std::fs::write(
        &child,
        "extends = \"base.toml\"\n\n[actors.a]\ninputs.x = { topic = \"t\", mailbox = \"fifo\" }\n",
    )
    .expect("child");
    let err = LoadedConfig::load(&child).unwrap_err();
    assert_eq!((err.file.as_path(), err.line), (child.as_path(), Some(4)), "{err}");
    std::fs::write(&child, "extends = \"base.toml\"\n\n[actors.a]\nparams.seed = 1\n").expect("child");
    let err = LoadedConfig::load(&child).unwrap_err();
    assert_eq!((err.file.as_path(), err.line), (base.as_path(), Some(6)), "{err}");
    assert!(err.message.contains("window_s"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}
