//! What the in-process hardware-in-the-loop fault flights share (tests/hil_pwm_fault.rs,
//! tests/hil_gps_loss.rs): the Navio2 graph on the emulated board flying the square mission,
//! a fault applied a while after the vehicle is airborne, and the run's report and recording.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use kestrel::hil::{HilOptions, apply_hil};
use kestrel::{LoadedConfig, Registry, RunOptions};
use kestrel_sim::hil::Navio2Bench;
use kestrel_sim::hil::navio2_sysfs::EscInput;

/// `config/navio2.toml` set to fly `config/missions/square.plan` by itself and stop once
/// landed, on an emulated board in its default directory (`kestrel::hil::bench_dir`, in
/// memory: `bench.config.dir`, for the test to remove).
pub fn square_on_the_bench() -> (LoadedConfig, Arc<Navio2Bench>) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut config = LoadedConfig::load(&root.join("config/navio2.toml")).expect("navio2.toml loads");
    for actor in config.graph.actors.values_mut() {
        if actor.kind.get_ref() == "commander" {
            let params =
                actor.params.get_or_insert_with(|| toml::Spanned::new(0..0, toml::Table::new())).get_mut();
            let plan = root.join("config/missions/square.plan").display().to_string();
            params.insert("mission".into(), plan.into());
            params.insert("auto".into(), true.into());
            params.insert("exit_on_land".into(), true.into());
        }
    }
    let bench = apply_hil(&mut config, &HilOptions::new()).expect("the bench builds");
    (config, bench)
}

/// Runs `fault` on a thread of its own 5 s after every motor first spins past 30 % (airborne);
/// the thread returns whether it ran (not when the motors never spun up within 2 minutes).
pub fn when_airborne(
    bench: &Arc<Navio2Bench>,
    fault: impl FnOnce(&Navio2Bench) + Send + 'static,
) -> JoinHandle<bool> {
    let bench = Arc::clone(bench);
    std::thread::spawn(move || {
        let deadline = Instant::now() + Duration::from_secs(120);
        let spinning = || {
            bench
                .pwm
                .read()
                .is_ok_and(|escs| escs.iter().all(|e| matches!(e, EscInput::Throttle(t) if *t > 0.3)))
        };
        while !spinning() {
            if Instant::now() > deadline {
                return false;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        std::thread::sleep(Duration::from_secs(5));
        fault(&bench);
        true
    })
}

/// Runs `config` (at most 200 s) recording every topic; returns the report's JSON and the
/// recording's path, both in `dir`.
pub fn fly(config: &LoadedConfig, dir: &Path) -> (serde_json::Value, PathBuf) {
    std::fs::create_dir_all(dir).expect("scratch dir");
    let (record, report_path) = (dir.join("flight.mcap"), dir.join("report.json"));
    let options = RunOptions {
        duration: Some(Duration::from_secs(200)),
        record: Some(record.clone()),
        report: Some(report_path.clone()),
        ..Default::default()
    };
    kestrel::run(config, &Registry::standard(), options).expect("the HIL flight ran");
    let report = serde_json::from_str(&std::fs::read_to_string(&report_path).expect("report")).expect("JSON");
    (report, record)
}
