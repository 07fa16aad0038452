//! The actor shell: ports it declares, what it publishes per step, and bad params.

use std::path::Path;
use std::time::Duration;

use kestrel_proto::messages::{
    ActuatorOutputs, GroundTruth, ImuSample, RangefinderOrientation, RangefinderSample,
};
use kestrel_proto::testing::{TestSetup, ready};
use kestrel_proto::{Actor, ActorError, Message, Time};
use kestrel_sim::{SimActor, SimActorParams, SimInput, hover_throttle};

fn setup() -> TestSetup<SimInput> {
    TestSetup::new("sim", Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config"))
}

fn params(toml_text: &str) -> SimActorParams {
    toml::from_str(toml_text).expect("params parse")
}

#[test]
fn publishes_every_stream_at_its_rate_and_flies_on_actuators() {
    let mut setup = setup();
    let params = params(
        "vehicle = \"vehicles/quad_x.toml\"\nworld = \"worlds/empty.toml\"\nseed = 3\ninitial_position_ned_m = [0.0, 0.0, -5.0]\n",
    );
    let mut actor = SimActor::build(&params, &mut setup).expect("builds");
    assert_eq!(
        setup.input_ports(),
        ["actuators", "calibration_motion", "param_set", "inject_failure", "esc_pulses"]
    );
    assert_eq!(setup.timers(), [("step", Duration::from_micros(2500))]);
    let ctx = setup.context();
    let hover = hover_throttle(actor.simulator().vehicle());
    let outputs = ActuatorOutputs { time: Time::ZERO, armed: true, motors: [hover; 8] };
    ready(actor.handle(&ctx, setup.input("actuators", outputs))).expect("actuators");
    for tick in 1..=800 {
        ready(actor.handle(&ctx, setup.tick("step", Time(tick * 2500)))).expect("step");
    }
    let count = |port: &str| setup.count(port);
    assert_eq!(count("imu"), 800);
    assert_eq!(count("imu_raw") + count("mag_raw"), 0, "raw samples only while a calibration asks");
    assert_eq!(count("ground_truth"), 100);
    assert_eq!(count("battery"), 20);
    assert_eq!(count("mag"), 200);
    assert_eq!(count("baro"), 20 - 1, "the last baro sample is still in its 50 ms lag");
    assert_eq!(count("gps"), 8, "the fixes of 1.8 s and 2.0 s are still in their 220 ms lag");
    // quad_x.toml's TFmini Pluses at 100 Hz: open sky above, the ground 4–5 m below.
    assert_eq!((count("rangefinder_up"), count("rangefinder_down")), (200, 200));
    let up = setup.published::<RangefinderSample>("rangefinder_up");
    assert!(up.iter().all(|s| s.orientation == RangefinderOrientation::Up && s.distance_m.is_none()));
    let down = &setup.published::<RangefinderSample>("rangefinder_down")[199];
    assert_eq!((down.time, down.orientation), (Time(2_000_000), RangefinderOrientation::Down));
    let imu = &setup.published::<ImuSample>("imu")[799];
    assert_eq!(imu.time(), Time(2_000_000));
    let truth = &setup.published::<GroundTruth>("ground_truth")[99];
    // The motors spin up from rest, so the vehicle sags about a metre before hover thrust holds it.
    assert!(truth.position_ned_m[2] < -3.5 && truth.acceleration_ned_m_s2[2].abs() < 0.2, "{truth:?}");
    assert!((truth.lat_deg - 6.79710).abs() < 1e-6 && !truth.landed);
    let height_m = -truth.position_ned_m[2];
    assert!(down.distance_m.is_some_and(|d| (d - height_m).abs() < 0.05), "{down:?} at {height_m} m");
}

#[test]
fn without_actuators_the_motors_stay_stopped() {
    let mut setup = setup();
    let mut actor =
        SimActor::build(&params("initial_position_ned_m = [0.0, 0.0, -1.0]\n"), &mut setup).expect("builds");
    let ctx = setup.context();
    ready(actor.handle(&ctx, SimInput::Step(Time(1_000_000)))).expect("step");
    assert!(actor.simulator().motor_speeds_rad_s().iter().all(|&w| w == 0.0));
    assert!(actor.simulator().landed());
}

#[test]
fn bad_params_are_param_errors_naming_the_problem() {
    let err =
        SimActor::build(&params("vehicle = \"vehicles/missing.toml\"\n"), &mut setup()).err().expect("fails");
    assert!(matches!(&err, ActorError::Params(m) if m.contains("missing.toml")), "{err}");
    let err = SimActor::build(&params("physics_substeps = 0\n"), &mut setup()).err().expect("fails");
    assert!(matches!(&err, ActorError::Params(m) if m.contains("physics_substeps")), "{err}");
    assert!(toml::from_str::<SimActorParams>("seeed = 1\n").is_err(), "unknown params are rejected");
}

#[test]
fn sizes_and_rates_too_large_to_simulate_are_refused_by_name() {
    let vehicle: kestrel_sim::VehicleParams =
        toml::from_str("[sensors.gps]\nrate_hz = 1e30\n").expect("parses");
    let err = vehicle.validate().expect_err("a 1e30 Hz GPS would size its lag queue for 10⁷ fixes");
    assert!(err.to_string().contains("sensors.gps.rate_hz"), "{err}");

    let forest = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/worlds/forest.toml"),
    )
    .expect("the forest world");
    let dir = std::env::temp_dir().join(format!("kestrel-sim-trees-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("huge_forest.toml");
    std::fs::write(&path, forest.replace("trees = 24", "trees = 1000000000000")).expect("write");
    let err = kestrel_sim::World::load(&path).expect_err("10¹² trees cannot be planted");
    assert!(err.to_string().contains("forest.trees"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

fn scratch_world(name: &str, text: &str) -> String {
    let dir = std::env::temp_dir().join(format!("kestrel-sim-actor-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write");
    path.display().to_string()
}

#[test]
fn world_faults_are_published_on_sim_fault_and_checked_against_the_vehicle() {
    use kestrel_proto::messages::{SimFault, SimFaultPhase};
    let world = scratch_world("imu_stop.toml", "[[faults]]\nat_s = 0.5\nfor_s = 0.5\nkind = \"imu_stop\"\n");
    let mut setup = setup();
    let mut actor = SimActor::build(&params(&format!("world = \"{world}\"\n")), &mut setup).expect("builds");
    assert!(setup.output_ports().contains(&"sim_fault"), "{:?}", setup.output_ports());
    let ctx = setup.context();
    for tick in 1..=800 {
        ready(actor.handle(&ctx, setup.tick("step", Time(tick * 2500)))).expect("step");
    }
    let events = setup.published::<SimFault>("sim_fault");
    let got: Vec<(u64, SimFaultPhase, &str)> =
        events.iter().map(|e| (e.time.0, e.phase, e.kind.as_str())).collect();
    assert_eq!(
        got,
        [(500_000, SimFaultPhase::Started, "imu_stop"), (1_000_000, SimFaultPhase::Ended, "imu_stop")]
    );
    assert_eq!(setup.count("imu"), 800 - 200, "0.5 s of 400 Hz samples missing");

    let world = scratch_world("motor5.toml", "[[faults]]\nat_s = 1.0\nkind = \"motor_lost\"\nmotor = 5\n");
    let err =
        SimActor::build(&params(&format!("world = \"{world}\"\n")), &mut self::setup()).err().expect("fails");
    assert!(
        matches!(&err, ActorError::Params(m) if m.contains("motor5.toml") && m.contains("faults[0].motor")),
        "{err}"
    );
}
