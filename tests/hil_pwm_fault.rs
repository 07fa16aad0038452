//! Issue 17's PWM fault on the hardware-in-the-loop graph: in flight, every write to the
//! emulated RCIO's `duty_cycle` files fails with EIO for 50 ms (the bench's fault switch, as the
//! co-processor's SPI link fails on a real board). The vehicle keeps flying — the motors keep
//! their last pulses while the output thread retries — finishes the square, lands, and the
//! failed writes are counted in the motors' `sensor_health`. No failsafe.
//!
//! Realtime, so it runs alone (`.config/nextest.toml`), like `tests/hil_flight.rs`.

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use kestrel::hil::{HilOptions, apply_hil};
use kestrel::recorder::LogReader;
use kestrel::{LoadedConfig, Registry, RunOptions};
use kestrel_proto::messages::SensorHealth;
use kestrel_sim::hil::navio2_sysfs::EscInput;

/// How long the writes fail.
const FAULT: Duration = Duration::from_millis(50);

#[test]
fn pwm_writes_failing_with_eio_for_50_ms_in_flight_are_retried_counted_and_the_flight_goes_on() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = std::env::temp_dir().join(format!("kestrel-hil-pwm-{}", std::process::id()));
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
    let options = HilOptions { dir: dir.join("bench"), ..HilOptions::new() };
    let bench = apply_hil(&mut config, &options).expect("the bench builds");

    // The operator's hand on the fault switch: 5 s after the motors first spin past 30 %
    // (airborne), the writes fail for 50 ms.
    let injected = Arc::new(AtomicBool::new(false));
    let injector = {
        let (bench, injected) = (Arc::clone(&bench), Arc::clone(&injected));
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
                    return;
                }
                std::thread::sleep(Duration::from_millis(20));
            }
            std::thread::sleep(Duration::from_secs(5));
            bench.fail_pwm_writes(true);
            std::thread::sleep(FAULT);
            bench.fail_pwm_writes(false);
            injected.store(true, Ordering::Relaxed);
        })
    };

    std::fs::create_dir_all(&dir).expect("scratch dir");
    let (record, report_path) = (dir.join("flight.mcap"), dir.join("report.json"));
    let options = RunOptions {
        duration: Some(Duration::from_secs(200)),
        record: Some(record.clone()),
        report: Some(report_path.clone()),
        ..Default::default()
    };
    kestrel::run(&config, &Registry::standard(), options).expect("the HIL flight ran");
    injector.join().expect("injector");
    assert!(injected.load(Ordering::Relaxed), "the motors never spun up: nothing was injected");

    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report_path).expect("report")).expect("JSON");
    println!(
        "report: mission {} flight {} failsafes {}",
        report["mission"], report["flight"], report["failsafes"]
    );
    assert_eq!(report["mission"]["completed"], true, "{report:#}");
    assert_eq!(report["flight"]["landed"], true, "{report:#}");
    let from_home = report["flight"]["landing_distance_from_home_m"].as_f64().expect("distance");
    assert!(from_home < 1.5, "landed {from_home} m from home");
    assert_eq!(report["failsafes"], serde_json::json!([]), "a 50 ms fault is no failsafe");

    let health =
        LogReader::open(&record).expect("log").read::<SensorHealth>("sensor_health").expect("health");
    let motors: Vec<&SensorHealth> =
        health.iter().map(|r| &r.message).filter(|h| h.sensor == "motors").collect();
    let errors: u64 = motors.iter().map(|h| h.errors).sum();
    let total = motors.last().map_or(0, |h| h.errors_total);
    println!(
        "motors' sensor_health: {errors} failed writes reported, {total} in all, {} reports",
        motors.len()
    );
    assert!(
        errors > 0 && errors == total,
        "the failed writes are counted: {errors} reported, {total} in all"
    );
    // Four channels written every 2.5 ms at most: no more failures than 50 ms (and a scheduling
    // margin) of retries can make.
    assert!(errors <= 4 * 40, "{errors} failed writes for a 50 ms fault");
    std::fs::remove_dir_all(&dir).ok();
}
