//! The actor shell: ports it declares, what it publishes per step, and bad params.

use std::any::Any;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::task::{Context as TaskContext, Poll, Waker};
use std::time::Duration;

use kestrel_proto::clock::Sleep;
use kestrel_proto::messages::{ActuatorOutputs, GroundTruth, ImuSample};
use kestrel_proto::{Actor, ActorError, Clock, Context, Message, Publisher, Setup, Sink, Time};
use kestrel_sim::{SimActor, SimActorParams, SimInput, hover_throttle};
use tokio_util::sync::CancellationToken;

struct FixedClock(Time);

impl Clock for FixedClock {
    fn now(&self) -> Time {
        self.0
    }
    fn sleep_until(&self, _deadline: Time) -> Sleep {
        Box::pin(std::future::ready(()))
    }
}

/// Everything published, per port.
#[derive(Default)]
struct Recorded(Mutex<HashMap<&'static str, Vec<Box<dyn Any + Send>>>>);

struct Port<T> {
    name: &'static str,
    log: Arc<Recorded>,
    _t: std::marker::PhantomData<fn(T)>,
}

impl<T: Message> Sink<T> for Port<T> {
    fn publish(&self, msg: T) {
        self.log.0.lock().unwrap().entry(self.name).or_default().push(Box::new(msg));
    }
}

struct TestSetup {
    dir: PathBuf,
    log: Arc<Recorded>,
    inputs: Vec<&'static str>,
    timers: Vec<(&'static str, Duration)>,
}

impl Setup<SimInput> for TestSetup {
    fn name(&self) -> &str {
        "sim"
    }
    fn config_dir(&self) -> &Path {
        &self.dir
    }
    fn clock(&self) -> Arc<dyn Clock> {
        Arc::new(FixedClock(Time::ZERO))
    }
    fn output<T: Message>(&mut self, port: &'static str) -> Publisher<T> {
        Publisher::new(Arc::new(Port::<T> {
            name: port,
            log: Arc::clone(&self.log),
            _t: std::marker::PhantomData,
        }))
    }
    fn input<T: Message>(&mut self, port: &'static str, _wrap: fn(T) -> SimInput) {
        self.inputs.push(port);
    }
    fn timer(&mut self, port: &'static str, period: Duration, _tick: fn(Time) -> SimInput) {
        self.timers.push((port, period));
    }
}

fn setup() -> TestSetup {
    TestSetup {
        dir: Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config"),
        log: Arc::default(),
        inputs: Vec::new(),
        timers: Vec::new(),
    }
}

/// Polls a future that never waits (the simulator's handlers do no I/O).
fn ready<F: Future>(future: F) -> F::Output {
    let mut future = std::pin::pin!(future);
    match future.as_mut().poll(&mut TaskContext::from_waker(Waker::noop())) {
        Poll::Ready(output) => output,
        Poll::Pending => panic!("the simulator's handler waited"),
    }
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
    assert_eq!(setup.inputs, ["actuators"]);
    assert_eq!(setup.timers, [("step", Duration::from_micros(2500))]);
    let ctx = Context::new("sim".into(), Arc::new(FixedClock(Time::ZERO)), CancellationToken::new());
    let hover = hover_throttle(actor.simulator().vehicle());
    let outputs = ActuatorOutputs { time: Time::ZERO, armed: true, motors: [hover; 8] };
    ready(actor.handle(&ctx, SimInput::Actuators(outputs))).expect("actuators");
    for tick in 1..=800 {
        ready(actor.handle(&ctx, SimInput::Step(Time(tick * 2500)))).expect("step");
    }
    let log = setup.log.0.lock().unwrap();
    let count = |port: &str| log.get(port).map_or(0, Vec::len);
    assert_eq!(count("imu"), 800);
    assert_eq!(count("ground_truth"), 100);
    assert_eq!(count("battery"), 20);
    assert_eq!(count("mag"), 200);
    assert_eq!(count("baro"), 20 - 1, "the last baro sample is still in its 50 ms lag");
    assert_eq!(count("gps"), 8, "the fixes of 1.8 s and 2.0 s are still in their 220 ms lag");
    let imu = log["imu"][799].downcast_ref::<ImuSample>().expect("an ImuSample");
    assert_eq!(imu.time(), Time(2_000_000));
    let truth = log["ground_truth"][99].downcast_ref::<GroundTruth>().expect("a GroundTruth");
    // The motors spin up from rest, so the vehicle sags about a metre before hover thrust holds it.
    assert!(truth.position_ned_m[2] < -3.5 && truth.acceleration_ned_m_s2[2].abs() < 0.2, "{truth:?}");
    assert!((truth.lat_deg - 6.79710).abs() < 1e-6 && !truth.landed);
}

#[test]
fn without_actuators_the_motors_stay_stopped() {
    let mut setup = setup();
    let mut actor =
        SimActor::build(&params("initial_position_ned_m = [0.0, 0.0, -1.0]\n"), &mut setup).expect("builds");
    let ctx = Context::new("sim".into(), Arc::new(FixedClock(Time::ZERO)), CancellationToken::new());
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
