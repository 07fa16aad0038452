//! An in-memory stand-in for the runtime, for unit tests of one actor.
//!
//! [`TestSetup`] is the [`Setup`] an actor is built with in a test: it remembers the ports the
//! actor declared, turns messages into the actor's input type the way the runtime would, and
//! keeps everything the actor publishes, per port and in order. [`ready`] runs one handler to
//! completion. Whole-graph behaviour (mailboxes, lockstep, restarts) is tested against the real
//! runtime instead.

use std::any::Any;
use std::collections::HashMap;
use std::future::Future;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::task::{Context as TaskContext, Poll, Waker};
use std::time::Duration;

use tokio_util::sync::CancellationToken;

use crate::actor::{Context, Publisher, Setup, Sink};
use crate::clock::{Clock, Sleep};
use crate::keepsake::Keepsake;
use crate::message::Message;
use crate::time::Time;

/// A clock that moves only when the test says so; sleeps complete at once.
#[derive(Debug, Default)]
pub struct ManualClock {
    now_us: AtomicU64,
}

impl ManualClock {
    /// Sets the time.
    pub fn set(&self, t: Time) {
        self.now_us.store(t.as_micros(), Ordering::Release);
    }
}

impl Clock for ManualClock {
    fn now(&self) -> Time {
        Time::from_micros(self.now_us.load(Ordering::Acquire))
    }

    fn sleep_until(&self, _deadline: Time) -> Sleep {
        Box::pin(std::future::ready(()))
    }
}

type Published = Arc<Mutex<HashMap<&'static str, Vec<Box<dyn Any + Send>>>>>;

struct RecordingSink<T> {
    port: &'static str,
    published: Published,
    _message: std::marker::PhantomData<fn(T)>,
}

impl<T: Message> Sink<T> for RecordingSink<T> {
    fn publish(&self, msg: T) {
        self.published
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .entry(self.port)
            .or_default()
            .push(Box::new(msg));
    }
}

/// The [`Setup`] of a unit test; `I` is the actor's input type.
pub struct TestSetup<I> {
    name: String,
    config_dir: PathBuf,
    clock: Arc<ManualClock>,
    published: Published,
    outputs: Vec<&'static str>,
    inputs: Vec<(&'static str, Box<dyn Any + Send>)>,
    timers: Vec<Timer<I>>,
    /// Kept across builds on this setup, so a test builds an actor again as a restart does.
    keepsakes: HashMap<&'static str, Box<dyn Any + Send>>,
}

/// A declared timer: port, period and how its tick becomes an input.
type Timer<I> = (&'static str, Duration, fn(Time) -> I);

impl<I: 'static> TestSetup<I> {
    /// A setup for an actor called `name` whose config lives in `config_dir`.
    pub fn new(name: &str, config_dir: impl Into<PathBuf>) -> Self {
        TestSetup {
            name: name.to_owned(),
            config_dir: config_dir.into(),
            clock: Arc::default(),
            published: Arc::default(),
            outputs: Vec::new(),
            inputs: Vec::new(),
            timers: Vec::new(),
            keepsakes: HashMap::new(),
        }
    }

    /// The clock handed to the actor.
    pub fn manual_clock(&self) -> &Arc<ManualClock> {
        &self.clock
    }

    /// A running actor's context on this setup's clock.
    pub fn context(&self) -> Context {
        Context::new(Arc::from(self.name.as_str()), self.clock.clone(), CancellationToken::new())
    }

    /// Output ports, in declaration order.
    pub fn output_ports(&self) -> Vec<&'static str> {
        self.outputs.clone()
    }

    /// Input ports, in declaration order.
    pub fn input_ports(&self) -> Vec<&'static str> {
        self.inputs.iter().map(|(port, _)| *port).collect()
    }

    /// Timers and their periods, in declaration order.
    pub fn timers(&self) -> Vec<(&'static str, Duration)> {
        self.timers.iter().map(|(port, period, _)| (*port, *period)).collect()
    }

    /// `msg` as the actor receives it on input `port`. Panics (a test failure) if the actor did
    /// not declare that port with that message type.
    pub fn input<T: Message>(&self, port: &str, msg: T) -> I {
        let wrap = self
            .inputs
            .iter()
            .find(|(p, _)| *p == port)
            .unwrap_or_else(|| panic!("no input port '{port}'"))
            .1
            .downcast_ref::<fn(T) -> I>()
            .unwrap_or_else(|| panic!("input port '{port}' does not take {}", T::TYPE_NAME));
        wrap(msg)
    }

    /// The tick timer `port` delivers at `t`.
    pub fn tick(&self, port: &str, t: Time) -> I {
        let (_, _, tick) =
            self.timers.iter().find(|(p, _, _)| *p == port).unwrap_or_else(|| panic!("no timer '{port}'"));
        tick(t)
    }

    /// Everything published on output `port` so far, in order.
    pub fn published<T: Message>(&self, port: &str) -> Vec<T> {
        let published = self.published.lock().unwrap_or_else(|e| e.into_inner());
        published.get(port).map_or_else(Vec::new, |msgs| {
            msgs.iter()
                .map(|m| {
                    m.downcast_ref::<T>()
                        .unwrap_or_else(|| panic!("port '{port}' does not carry {}", T::TYPE_NAME))
                        .clone()
                })
                .collect()
        })
    }

    /// How many messages output `port` has published.
    pub fn count(&self, port: &str) -> usize {
        self.published.lock().unwrap_or_else(|e| e.into_inner()).get(port).map_or(0, Vec::len)
    }
}

impl<I: 'static> Setup<I> for TestSetup<I> {
    fn name(&self) -> &str {
        &self.name
    }

    fn config_dir(&self) -> &Path {
        &self.config_dir
    }

    fn clock(&self) -> Arc<dyn Clock> {
        self.clock.clone()
    }

    fn output<T: Message>(&mut self, port: &'static str) -> Publisher<T> {
        self.outputs.push(port);
        Publisher::new(Arc::new(RecordingSink::<T> {
            port,
            published: Arc::clone(&self.published),
            _message: std::marker::PhantomData,
        }))
    }

    fn input<T: Message>(&mut self, port: &'static str, wrap: fn(T) -> I) {
        self.inputs.push((port, Box::new(wrap)));
    }

    fn timer(&mut self, port: &'static str, period: Duration, tick: fn(Time) -> I) {
        self.timers.push((port, period, tick));
    }

    fn keepsake<T: Clone + Send + 'static>(&mut self, name: &'static str) -> Keepsake<T> {
        let kept = self.keepsakes.entry(name).or_insert_with(|| Box::new(Keepsake::<T>::new()));
        kept.downcast_ref::<Keepsake<T>>().expect("one type per keepsake name in a test").clone()
    }
}

/// Runs a future that does not wait on anything (an actor handler without I/O) to completion.
/// Panics (a test failure) if it would wait.
pub fn ready<F: Future>(future: F) -> F::Output {
    let mut future = std::pin::pin!(future);
    match future.as_mut().poll(&mut TaskContext::from_waker(Waker::noop())) {
        Poll::Ready(output) => output,
        Poll::Pending => panic!("the handler waited on something"),
    }
}

/// A commander's status with nothing to report beyond arming, mode and landed state: no
/// failsafe, no mission, no refusal, home unknown, geofence on, every motor healthy. Tests set
/// the fields they are about on top of it.
pub fn vehicle_status(
    time: Time,
    armed: bool,
    mode: crate::messages::FlightMode,
    landed: crate::messages::LandedState,
) -> crate::messages::VehicleStatus {
    crate::messages::VehicleStatus {
        time,
        armed,
        mode,
        landed,
        failsafe: None,
        mission: crate::messages::MissionProgress::default(),
        last_refusal: None,
        refusals: 0,
        armable: false,
        home: None,
        geofence_enabled: true,
        failed_motor: None,
        speed_cap: None,
        vertical_limit: None,
        fence: crate::messages::FenceStatus::default(),
    }
}
