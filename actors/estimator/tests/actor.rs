//! The actor shell: its ports, what it publishes for a sample stream, and bad parameters.

use kestrel_estimator::{EkfParams, EstimatorActor, EstimatorInput};
use kestrel_proto::messages::{EstimatorStatus, NavState};
use kestrel_proto::testing::{TestSetup, ready};
use kestrel_proto::{Actor, ActorError, Time};
use kestrel_sim::{SimOptions, SimOutput, Simulator, VehicleParams, World};

fn setup() -> TestSetup<EstimatorInput> {
    TestSetup::new("estimator", ".")
}

#[test]
fn declares_its_ports_and_publishes_nav_state_per_imu_sample_and_status_at_10_hz() {
    let mut setup = setup();
    let mut actor = EstimatorActor::build(&EkfParams::default(), &mut setup).expect("builds");
    assert_eq!(setup.input_ports(), ["imu", "imu2", "gps", "baro", "mag", "param_set", "vehicle_status"]);
    assert_eq!(setup.output_ports(), ["nav_state", "estimator_status", "param_decl"]);
    assert!(setup.timers().is_empty(), "the estimator runs on sample time, not on timers");

    let ctx = setup.context();
    let mut sim = Simulator::new(VehicleParams::default(), World::default(), SimOptions::default()).unwrap();
    let mut imu_samples = 0;
    for _ in 0..1600 {
        sim.step();
        let outputs: Vec<SimOutput> = sim.drain().collect();
        for out in outputs {
            let input = match out {
                SimOutput::Imu(s) => {
                    imu_samples += 1;
                    EstimatorInput::Imu(0, s)
                }
                SimOutput::Imu2(s) => EstimatorInput::Imu(1, s),
                SimOutput::Gps(f) => EstimatorInput::Gps(f),
                SimOutput::Baro(b) => EstimatorInput::Baro(b),
                SimOutput::Mag(m) => EstimatorInput::Mag(m),
                SimOutput::GroundTruth(_)
                | SimOutput::Rangefinder(_)
                | SimOutput::Battery(_)
                | SimOutput::Esc(_)
                | SimOutput::Fault(_) => continue,
            };
            ready(actor.handle(&ctx, input)).expect("handled");
        }
    }
    let nav = setup.published::<NavState>("nav_state");
    let status = setup.published::<EstimatorStatus>("estimator_status");
    // Alignment takes the first second of still samples; every IMU sample after it gives a state.
    assert!(nav.len() > imu_samples - 420 && nav.len() < imu_samples - 390, "{} of {imu_samples}", nav.len());
    assert!((38..=41).contains(&status.len()), "{} status messages in 4 s", status.len());
    let last = nav.last().unwrap();
    assert_eq!(last.time, Time::from_secs_f64(4.0));
    assert!(last.valid.horizontal_position && last.origin.is_some(), "{last:?}");
    let distance = last.position_ned_m.iter().map(|x| x * x).sum::<f64>().sqrt();
    assert!(distance < 1.0, "{last:?}");
    let last_status = status.last().unwrap();
    assert!(last_status.health.gps_fusing && last_status.gps.fused > 0, "{last_status:?}");
}

#[test]
fn bad_parameters_are_refused_at_build() {
    let err = toml::from_str::<EkfParams>("gps_lag_ms = 220").unwrap_err();
    assert!(err.to_string().contains("gps_lag_ms"), "{err}");
    let params: EkfParams = toml::from_str("gps_gate_sigma = -1.0").unwrap();
    let result = EstimatorActor::build(&params, &mut setup());
    assert!(matches!(result, Err(ActorError::Params(ref m)) if m.contains("gps_gate_sigma")));
}

#[test]
fn a_bad_sample_is_counted_not_fatal() {
    let mut setup = setup();
    let mut actor = EstimatorActor::build(&EkfParams::default(), &mut setup).expect("builds");
    let ctx = setup.context();
    let bad = kestrel_proto::messages::ImuSample {
        time: Time::from_micros(2500),
        gyro_rad_s: [f64::NAN; 3],
        accel_m_s2: [0.0; 3],
        dt_s: 0.0025,
        gyro_clipped: [false; 3],
        accel_clipped: [false; 3],
    };
    ready(actor.handle(&ctx, EstimatorInput::Imu(0, bad.clone())))
        .expect("a bad sample does not stop the actor");
    assert_eq!(actor.rejected_inputs(), 1, "the bad sample is counted");
    let good = kestrel_proto::messages::ImuSample {
        time: Time::from_micros(5000),
        gyro_rad_s: [0.0; 3],
        accel_m_s2: [0.0, 0.0, -9.8],
        ..bad
    };
    ready(actor.handle(&ctx, EstimatorInput::Imu(0, good))).expect("a good sample is handled");
    assert_eq!(actor.rejected_inputs(), 1, "a good sample after it is not");
    assert!(
        setup.published::<NavState>("nav_state").is_empty(),
        "nothing published for it (not yet aligned)"
    );
}

/// A simulator whose board has a second IMU (`[sensors.imu2]`), on the ground.
fn two_imu_sim() -> Simulator {
    let mut vehicle = VehicleParams::default();
    vehicle.sensors.imu2 = Some(kestrel_sim::sensors::ImuParams {
        gyro_bias_initial_rad_s: [0.002, -0.001, 0.0],
        ..Default::default()
    });
    Simulator::new(vehicle, World::default(), SimOptions::default()).unwrap()
}

/// Steps `sim` for `seconds`, handing every sample to `actor` except the first IMU's from
/// `first_imu_stops_at_s` on.
fn feed(
    sim: &mut Simulator,
    actor: &mut EstimatorActor,
    ctx: &kestrel_proto::Context,
    seconds: f64,
    first_imu_stops_at_s: f64,
) {
    let end = Time::from_secs_f64(sim.time().as_secs_f64() + seconds);
    while sim.time() < end {
        sim.step();
        let outputs: Vec<SimOutput> = sim.drain().collect();
        for out in outputs {
            let input = match out {
                SimOutput::Imu(s) if s.time.as_secs_f64() < first_imu_stops_at_s => EstimatorInput::Imu(0, s),
                SimOutput::Imu2(s) => EstimatorInput::Imu(1, s),
                SimOutput::Gps(f) => EstimatorInput::Gps(f),
                SimOutput::Baro(b) => EstimatorInput::Baro(b),
                SimOutput::Mag(m) => EstimatorInput::Mag(m),
                _ => continue,
            };
            ready(actor.handle(ctx, input)).expect("handled");
        }
    }
}

#[test]
fn the_first_imu_falling_silent_moves_the_prediction_to_the_second_without_a_gap() {
    let mut setup = setup();
    let mut actor = EstimatorActor::build(&EkfParams::default(), &mut setup).expect("builds");
    let ctx = setup.context();
    let mut sim = two_imu_sim();
    feed(&mut sim, &mut actor, &ctx, 6.0, 3.0);
    let nav = setup.published::<NavState>("nav_state");
    // One state per 2.5 ms from alignment on, through the switch: the 20 ms the switch waits are
    // predicted across in one step, so only those 7 samples give no state.
    let after_switch: Vec<&NavState> = nav.iter().filter(|n| n.time.as_secs_f64() > 3.0).collect();
    let expected = (3.0 / 0.0025) as usize - 8;
    assert!(
        after_switch.len().abs_diff(expected) <= 1,
        "{} states after 3 s, {expected} expected",
        after_switch.len()
    );
    let gaps = after_switch.windows(2).map(|w| (w[1].time - w[0].time).as_secs_f64()).fold(0.0, f64::max);
    assert!(gaps < 0.03, "largest interval between states after the switch {gaps} s");
    let last = nav.last().unwrap();
    assert!(last.valid.horizontal_position && last.valid.attitude, "{last:?}");
    let distance = last.position_ned_m.iter().map(|x| x * x).sum::<f64>().sqrt();
    assert!(distance < 1.0, "{last:?}");
    let status = setup.published::<EstimatorStatus>("estimator_status");
    let last_status = status.last().unwrap();
    assert_eq!(last_status.health.imu_switches, 1, "{last_status:?}");
    assert_eq!(last_status.health.imu_gaps, 0, "a switch is no gap: {last_status:?}");
}

#[test]
fn a_restarted_estimator_resumes_the_filter_its_predecessor_kept() {
    let mut setup = setup();
    let mut first = EstimatorActor::build(&EkfParams::default(), &mut setup).expect("builds");
    let ctx = setup.context();
    let mut sim = two_imu_sim();
    feed(&mut sim, &mut first, &ctx, 3.0, f64::INFINITY);
    let states_before = setup.count("nav_state");
    assert!(states_before > 0, "aligned before the failure");
    drop(first);
    // Built again on the same setup, as the supervisor does after a panic.
    let mut second = EstimatorActor::build(&EkfParams::default(), &mut setup).expect("builds");
    feed(&mut sim, &mut second, &ctx, 0.1, f64::INFINITY);
    // A cold estimator would need a second of still samples before its first state.
    let resumed = setup.count("nav_state") - states_before;
    assert!(resumed >= 39, "{resumed} states in the 0.1 s after the restart");
    feed(&mut sim, &mut second, &ctx, 1.0, f64::INFINITY);
    let status = setup.published::<EstimatorStatus>("estimator_status");
    assert_eq!(status.last().unwrap().health.warm_starts, 1);
    let nav = setup.published::<NavState>("nav_state");
    let last = nav.last().unwrap();
    assert!(last.valid.horizontal_position, "{last:?}");
}
