//! A PWM fault on the hardware-in-the-loop graph: in flight, every write to the
//! emulated RCIO's `duty_cycle` files fails with EIO for 50 ms (the bench's fault switch, as the
//! co-processor's SPI link fails on a real board). The vehicle keeps flying — the motors keep
//! their last pulses while the output thread retries — finishes the square, lands, and the
//! failed writes are counted in the motors' `sensor_health`. No failsafe.
//!
//! Realtime, so it runs alone (`.config/nextest.toml`), like `tests/hil_flight.rs`.

mod support;
use support::hil_square;

use kestrel::recorder::LogReader;
use kestrel_proto::messages::SensorHealth;

/// How long the writes fail.
const FAULT: std::time::Duration = std::time::Duration::from_millis(50);

#[test]
fn pwm_writes_failing_with_eio_for_50_ms_in_flight_are_retried_counted_and_the_flight_goes_on() {
    let dir = std::env::temp_dir().join(format!("kestrel-hil-pwm-{}", std::process::id()));
    let (config, bench) = hil_square::square_on_the_bench();
    let injector = hil_square::when_airborne(&bench, |bench| {
        bench.fail_pwm_writes(true);
        std::thread::sleep(FAULT);
        bench.fail_pwm_writes(false);
    });
    let (report, record) = hil_square::fly(&config, &dir);
    assert!(injector.join().expect("injector"), "the motors never spun up: nothing was injected");

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
    std::fs::remove_dir_all(&bench.config.dir).ok();
}
