//! Issue 17's GPS fault on the hardware-in-the-loop graph: in flight the u-blox receiver's line
//! (the emulated board's pseudo-terminal) goes away for 10 s, as a connector shaken loose, and
//! comes back as a receiver that lost power (at its 9600 baud factory rate). The GPS driver
//! keeps trying its device and sets the receiver up again when it reappears, without failing;
//! the estimator dead-reckons and reports the loss (`gps_lost`), the commander lands as the
//! fault matrix's "GPS lost" rows do (`estimator_unhealthy` → land), and GPS is fused again
//! once the line is back.
//!
//! Realtime, so it runs alone (`.config/nextest.toml`), like `tests/hil_flight.rs`.

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use kestrel::hil::{HilOptions, apply_hil};
use kestrel::recorder::LogReader;
use kestrel::{LoadedConfig, Registry, RunOptions};
use kestrel_proto::messages::{EstimatorStatus, GpsFix, SensorHealth, SupervisorEvent};
use kestrel_sim::hil::UbloxReceiver;
use kestrel_sim::hil::navio2_sysfs::EscInput;
use kestrel_sim::hil::pty::Pty;

/// How long the line is gone.
const UNPLUGGED: Duration = Duration::from_secs(10);

#[test]
fn the_gps_line_gone_for_10_s_in_flight_is_dead_reckoned_reported_and_taken_up_again() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = std::env::temp_dir().join(format!("kestrel-hil-gps-{}", std::process::id()));
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

    // 5 s after the motors first spin past 30 % (airborne), the line goes for 10 s.
    let replugged = Arc::new(AtomicBool::new(false));
    let injector = {
        let (bench, replugged) = (Arc::clone(&bench), Arc::clone(&replugged));
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
            bench.gps().pty = None;
            std::thread::sleep(UNPLUGGED);
            let pty = Pty::open(&bench.config.gps_device(), 9600).expect("the line again");
            let mut line = bench.gps();
            line.receiver = UbloxReceiver::new();
            line.pty = Some(pty);
            replugged.store(true, Ordering::Relaxed);
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
    assert!(replugged.load(Ordering::Relaxed), "the motors never spun up: nothing was injected");

    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report_path).expect("report")).expect("JSON");
    println!("report: flight {} failsafes {}", report["flight"], report["failsafes"]);
    assert_eq!(report["flight"]["landed"], true, "landed intact: {report:#}");
    assert_eq!(report["flight"]["crashed"], false, "{report:#}");
    let failsafes = report["failsafes"].as_array().expect("failsafes");
    assert!(
        failsafes.iter().any(|f| f["cause"] == "estimator_unhealthy" && f["action"] == "land"),
        "the matrix's GPS-lost outcome: {failsafes:?}"
    );

    let log = LogReader::open(&record).expect("log");
    let fixes: Vec<GpsFix> = log.read::<GpsFix>("gps").expect("gps").into_iter().map(|r| r.message).collect();
    let (gap_at, gap) = fixes
        .windows(2)
        .map(|w| (w[0].time, w[1].time - w[0].time))
        .max_by_key(|(_, gap)| *gap)
        .expect("fixes");
    println!("the longest silence of GPS: {:.1} s from {gap_at}", gap.as_secs_f64());
    assert!(gap >= Duration::from_secs(9) && gap <= Duration::from_secs(16), "the unplugged line: {gap:?}");
    let after: Vec<&GpsFix> = fixes.iter().filter(|f| f.time > gap_at + gap).collect();
    assert!(after.len() >= 5, "fixes came back: {} after the gap", after.len());

    let status = log.read::<EstimatorStatus>("estimator_status").expect("status");
    let lost = status.iter().any(|s| s.message.time > gap_at && !s.message.health.gps_fusing);
    let fused_again = status.iter().any(|s| s.message.time > gap_at + gap && s.message.health.gps_fusing);
    assert!(lost && fused_again, "GPS lost, then fused again: lost {lost}, fused again {fused_again}");

    let health = log.read::<SensorHealth>("sensor_health").expect("health");
    let gps_errors: u64 =
        health.iter().map(|r| &r.message).filter(|h| h.sensor == "gps").map(|h| h.errors).sum();
    assert!(gps_errors >= 1, "the loss is counted in the GPS health");
    let events = log.read::<SupervisorEvent>("supervisor").unwrap_or_default();
    let gps_failures: Vec<&SupervisorEvent> =
        events.iter().map(|r| &r.message).filter(|e| e.actor == "gps").collect();
    assert!(
        gps_failures.is_empty(),
        "the GPS driver took its line up again without failing: {gps_failures:?}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
