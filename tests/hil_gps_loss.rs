//! A GPS fault on the hardware-in-the-loop graph: in flight the u-blox receiver's line
//! (the emulated board's pseudo-terminal) goes away for 10 s, as a connector shaken loose, and
//! comes back as a receiver that lost power (at its 9600 baud factory rate). The GPS driver
//! keeps trying its device and sets the receiver up again when it reappears, without failing;
//! the estimator dead-reckons and reports the loss (`gps_lost`), the commander lands as the
//! fault matrix's "GPS lost" rows do (`estimator_unhealthy` → land), and GPS is fused again
//! once the line is back.
//!
//! Realtime, so it runs alone (`.config/nextest.toml`), like `tests/hil_flight.rs`.

mod support;
use support::hil_square;

use std::time::Duration;

use kestrel::recorder::LogReader;
use kestrel_proto::messages::{EstimatorStatus, GpsFix, SensorHealth, SupervisorEvent};
use kestrel_sim::hil::UbloxReceiver;
use kestrel_sim::hil::pty::Pty;

/// How long the line is gone.
const UNPLUGGED: Duration = Duration::from_secs(10);

#[test]
fn the_gps_line_gone_for_10_s_in_flight_is_dead_reckoned_reported_and_taken_up_again() {
    let dir = std::env::temp_dir().join(format!("kestrel-hil-gps-{}", std::process::id()));
    let (config, bench) = hil_square::square_on_the_bench();
    // The line goes, then comes back as a receiver that lost power (at its factory rate).
    let injector = hil_square::when_airborne(&bench, |bench| {
        bench.gps().pty = None;
        std::thread::sleep(UNPLUGGED);
        let pty = Pty::open(&bench.config.gps_device(), 9600).expect("the line again");
        let mut line = bench.gps();
        line.receiver = UbloxReceiver::new();
        line.pty = Some(pty);
    });
    let (report, record) = hil_square::fly(&config, &dir);
    assert!(injector.join().expect("injector"), "the motors never spun up: nothing was injected");

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
    std::fs::remove_dir_all(&bench.config.dir).ok();
}
