//! The default graph (`config/sim.toml`) run in-process on the lockstep clock.

use std::path::{Path, PathBuf};
use std::time::Duration;

use kestrel::{LoadedConfig, Registry, RunOptions, run};

fn temp_path(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("kestrel-{}-{name}", std::process::id()))
}

fn record_sim(seconds: f64, path: &Path) {
    let config = LoadedConfig::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("config/sim.toml")).unwrap();
    let options = RunOptions {
        duration: Some(Duration::from_secs_f64(seconds)),
        speedup: Some(0.0),
        record: Some(path.to_owned()),
        ..Default::default()
    };
    let report = run(&config, &Registry::standard(), options).unwrap();
    assert!(report.supervisor_events.is_empty(), "{:?}", report.supervisor_events);
    assert!(report.mailboxes.iter().all(|m| m.overflowed == 0), "{:?}", report.mailboxes);
}

#[test]
fn lockstep_run_records_bit_identical_logs_twice() {
    let (a, b) = (temp_path("det-a.mcap"), temp_path("det-b.mcap"));
    record_sim(5.0, &a);
    record_sim(5.0, &b);
    let (bytes_a, bytes_b) = (std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    let _ = (std::fs::remove_file(&a), std::fs::remove_file(&b));
    assert!(bytes_a.len() > 10_000, "a 5 s log holds thousands of messages ({} bytes)", bytes_a.len());
    assert!(bytes_a == bytes_b, "two lockstep runs differ ({} vs {} bytes)", bytes_a.len(), bytes_b.len());
}
