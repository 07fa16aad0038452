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
    assert_eq!(setup.input_ports(), ["imu", "gps", "baro", "mag", "param_set"]);
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
                    EstimatorInput::Imu(s)
                }
                SimOutput::Gps(f) => EstimatorInput::Gps(f),
                SimOutput::Baro(b) => EstimatorInput::Baro(b),
                SimOutput::Mag(m) => EstimatorInput::Mag(m),
                SimOutput::GroundTruth(_) | SimOutput::Battery(_) | SimOutput::Fault(_) => continue,
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
    ready(actor.handle(&ctx, EstimatorInput::Imu(bad.clone())))
        .expect("a bad sample does not stop the actor");
    assert_eq!(actor.rejected_inputs(), 1, "the bad sample is counted");
    let good = kestrel_proto::messages::ImuSample {
        time: Time::from_micros(5000),
        gyro_rad_s: [0.0; 3],
        accel_m_s2: [0.0, 0.0, -9.8],
        ..bad
    };
    ready(actor.handle(&ctx, EstimatorInput::Imu(good))).expect("a good sample is handled");
    assert_eq!(actor.rejected_inputs(), 1, "a good sample after it is not");
    assert!(
        setup.published::<NavState>("nav_state").is_empty(),
        "nothing published for it (not yet aligned)"
    );
}
