//! Hardware-in-the-loop faults at start-up: the Navio2 graph on an emulated board
//! whose IMU is the wrong part refuses to start, and the error names the device and what it read.
//! Each test binary is a process of its own, so the board plugged in here is this test's alone.

use std::path::Path;

use kestrel::hil::{HilOptions, apply_hil};
use kestrel::{LoadedConfig, Registry, RunError, RunOptions};

#[test]
fn an_imu_answering_a_wrong_who_am_i_stops_the_start_naming_the_device() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut config = LoadedConfig::load(&root.join("config/navio2.toml")).expect("navio2.toml loads");
    // 0x68 is an MPU-6050/6000: a real InvenSense part, not the one the graph drives.
    let options = HilOptions { imu_who_am_i: 0x68, ..HilOptions::new() };
    let _bench = apply_hil(&mut config, &options).expect("the bench builds");
    let run = kestrel::run(&config, &Registry::standard(), RunOptions::default());
    std::fs::remove_dir_all(&options.dir).ok();
    let Err(RunError::Config(errors)) = run else { panic!("the run started on a wrong IMU: {run:?}") };
    let text: Vec<String> = errors.iter().map(ToString::to_string).collect();
    let imu = text.iter().find(|e| e.contains("WHO_AM_I")).unwrap_or_else(|| panic!("{text:#?}"));
    assert!(imu.contains("/dev/spidev0.1") && imu.contains("0x68"), "{imu}");
    assert_eq!(text.len(), 1, "only the IMU is at fault: {text:#?}");
}
