//! The actor shell: its ports, what it publishes for a sample stream, and bad parameters.

use std::any::Any;
use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::task::{Context as TaskContext, Poll, Waker};
use std::time::Duration;

use kestrel_estimator::{EkfParams, EstimatorActor, EstimatorInput};
use kestrel_proto::clock::Sleep;
use kestrel_proto::messages::{EstimatorStatus, NavState};
use kestrel_proto::{Actor, ActorError, Clock, Context, Message, Publisher, Setup, Sink, Time};
use kestrel_sim::{SimOptions, SimOutput, Simulator, VehicleParams, World};
use tokio_util::sync::CancellationToken;

struct FixedClock;

impl Clock for FixedClock {
    fn now(&self) -> Time {
        Time::ZERO
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

#[derive(Default)]
struct TestSetup {
    log: Arc<Recorded>,
    inputs: Vec<&'static str>,
    outputs: Vec<&'static str>,
    timers: Vec<(&'static str, Duration)>,
}

impl Setup<EstimatorInput> for TestSetup {
    fn name(&self) -> &str {
        "estimator"
    }
    fn config_dir(&self) -> &Path {
        Path::new(".")
    }
    fn clock(&self) -> Arc<dyn Clock> {
        Arc::new(FixedClock)
    }
    fn output<T: Message>(&mut self, port: &'static str) -> Publisher<T> {
        self.outputs.push(port);
        Publisher::new(Arc::new(Port::<T> {
            name: port,
            log: Arc::clone(&self.log),
            _t: std::marker::PhantomData,
        }))
    }
    fn input<T: Message>(&mut self, port: &'static str, _wrap: fn(T) -> EstimatorInput) {
        self.inputs.push(port);
    }
    fn timer(&mut self, port: &'static str, period: Duration, _tick: fn(Time) -> EstimatorInput) {
        self.timers.push((port, period));
    }
}

/// Polls a future that never waits (the estimator's handler does no I/O and never sleeps).
fn ready<F: Future>(future: F) -> F::Output {
    let mut future = std::pin::pin!(future);
    match future.as_mut().poll(&mut TaskContext::from_waker(Waker::noop())) {
        Poll::Ready(output) => output,
        Poll::Pending => panic!("the estimator's handler waited"),
    }
}

#[test]
fn declares_its_ports_and_publishes_nav_state_per_imu_sample_and_status_at_10_hz() {
    let mut setup = TestSetup::default();
    let mut actor = EstimatorActor::build(&EkfParams::default(), &mut setup).expect("builds");
    assert_eq!(setup.inputs, ["imu", "gps", "baro", "mag"]);
    assert_eq!(setup.outputs, ["nav_state", "estimator_status"]);
    assert!(setup.timers.is_empty(), "the estimator runs on sample time, not on timers");

    let ctx = Context::new("estimator".into(), Arc::new(FixedClock), CancellationToken::new());
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
                SimOutput::GroundTruth(_) | SimOutput::Battery(_) => continue,
            };
            ready(actor.handle(&ctx, input)).expect("handled");
        }
    }
    let log = setup.log.0.lock().unwrap();
    let nav = &log["nav_state"];
    let status = &log["estimator_status"];
    // Alignment takes the first second of still samples; every IMU sample after it gives a state.
    assert!(nav.len() > imu_samples - 420 && nav.len() < imu_samples - 390, "{} of {imu_samples}", nav.len());
    assert!((38..=41).contains(&status.len()), "{} status messages in 4 s", status.len());
    let last = nav.last().unwrap().downcast_ref::<NavState>().unwrap();
    assert_eq!(last.time, Time::from_secs_f64(4.0));
    assert!(last.valid.horizontal_position && last.origin.is_some(), "{last:?}");
    let distance = last.position_ned_m.iter().map(|x| x * x).sum::<f64>().sqrt();
    assert!(distance < 1.0, "{last:?}");
    let last_status = status.last().unwrap().downcast_ref::<EstimatorStatus>().unwrap();
    assert!(last_status.health.gps_fusing && last_status.gps.fused > 0, "{last_status:?}");
}

#[test]
fn bad_parameters_are_refused_at_build() {
    let err = toml::from_str::<EkfParams>("gps_lag_ms = 220").unwrap_err();
    assert!(err.to_string().contains("gps_lag_ms"), "{err}");
    let params: EkfParams = toml::from_str("gps_gate_sigma = -1.0").unwrap();
    let result = EstimatorActor::build(&params, &mut TestSetup::default());
    assert!(matches!(result, Err(ActorError::Params(ref m)) if m.contains("gps_gate_sigma")));
}

#[test]
fn a_bad_sample_is_counted_not_fatal() {
    let mut setup = TestSetup::default();
    let mut actor = EstimatorActor::build(&EkfParams::default(), &mut setup).expect("builds");
    let ctx = Context::new("estimator".into(), Arc::new(FixedClock), CancellationToken::new());
    let bad = kestrel_proto::messages::ImuSample {
        time: Time::from_micros(2500),
        gyro_rad_s: [f64::NAN; 3],
        accel_m_s2: [0.0; 3],
        dt_s: 0.0025,
    };
    ready(actor.handle(&ctx, EstimatorInput::Imu(bad))).expect("a bad sample does not stop the actor");
}
