//! The actor contract.
//!
//! An actor is a struct that owns its state and sees the world only through messages:
//! * At (re)start the runtime calls [`Actor::build`] with the actor's parameters and a
//!   [`Setup`] through which it declares its ports: typed outputs (it keeps the returned
//!   [`Publisher`]s), typed inputs (each mapped into the actor's own `Input` enum), and
//!   periodic timers on the graph clock.
//! * The runtime then calls [`Actor::start`] once, [`Actor::handle`] for every input in arrival
//!   order, and [`Actor::stop`] on shutdown.
//!
//! Which topic each port is wired to, and whether an input keeps every message or only the
//! newest, is the config's business, not the actor's: the same actor runs on the simulator, on
//! hardware and on a replayed log.

use std::future::Future;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use tokio_util::sync::CancellationToken;

use crate::clock::Clock;
use crate::keepsake::Keepsake;
use crate::message::Message;
use crate::time::Time;

/// The receiving end of a topic: a publisher hands messages to it, it fans them out.
pub trait Sink<T>: Send + Sync {
    /// Delivers `msg` to every subscriber; never blocks, never fails (a full mailbox counts an
    /// overflow on its own side).
    fn publish(&self, msg: T);
}

/// A typed handle for one of an actor's outputs.
pub struct Publisher<T> {
    sink: Arc<dyn Sink<T>>,
}

impl<T> Clone for Publisher<T> {
    fn clone(&self) -> Self {
        Publisher { sink: Arc::clone(&self.sink) }
    }
}

impl<T: Message> Publisher<T> {
    /// Wraps a topic's sink; the runtime builds these, actors only use them.
    pub fn new(sink: Arc<dyn Sink<T>>) -> Self {
        Publisher { sink }
    }

    /// Publishes `msg` to every subscriber of the topic this output is wired to.
    pub fn publish(&self, msg: T) {
        self.sink.publish(msg);
    }
}

/// What an actor is given while it is built: its name, where its config lives, the clock, and
/// the means to declare ports.
///
/// `I` is the actor's input type (usually an enum with one variant per input port).
pub trait Setup<I> {
    /// The actor's name in the config, for messages and logs.
    fn name(&self) -> &str;

    /// The directory of the config file, against which relative paths in parameters resolve.
    fn config_dir(&self) -> &Path;

    /// The graph clock.
    fn clock(&self) -> Arc<dyn Clock>;

    /// Declares an output port. The config may rename the topic it publishes on; by default
    /// the topic has the port's name.
    fn output<T: Message>(&mut self, port: &'static str) -> Publisher<T>;

    /// Declares an input port; each message that arrives on it is passed to
    /// [`Actor::handle`] as `wrap(message)`. An input the config does not route stays silent.
    fn input<T: Message>(&mut self, port: &'static str, wrap: fn(T) -> I);

    /// Declares a periodic timer: every `period` on the graph clock, at multiples of `period`
    /// since the clock's origin, the actor receives `tick(scheduled_time)`. A tick that is still
    /// unhandled when the next one is due is conflated and counted as missed.
    fn timer(&mut self, port: &'static str, period: Duration, tick: fn(Time) -> I);

    /// Claims a device file the actor is about to open (spidev, I²C, a serial port, a PWM chip)
    /// for this process alone. Call it before opening the device, so a second process on the
    /// same board fails here, naming the first, instead of resetting a chip under it. The claim
    /// lasts for the whole run, restarts included. By default (a harness running one actor)
    /// nothing is claimed.
    fn claim_device(&mut self, device: &Path) -> Result<(), ActorError> {
        let _ = device;
        Ok(())
    }

    /// The actor's keepsake `name`: the same slot in every incarnation of this actor, so what
    /// one keeps its restarted successor can take ([`Keepsake`]). By default an empty slot of
    /// its own, for a harness that never builds the actor twice.
    fn keepsake<T: Clone + Send + 'static>(&mut self, name: &'static str) -> Keepsake<T> {
        let _ = name;
        Keepsake::new()
    }
}

/// Handed to a running actor with every call.
#[derive(Clone)]
pub struct Context {
    name: Arc<str>,
    clock: Arc<dyn Clock>,
    shutdown: CancellationToken,
    run: CancellationToken,
}

impl Context {
    /// Built by the runtime for each actor incarnation.
    pub fn new(name: Arc<str>, clock: Arc<dyn Clock>, shutdown: CancellationToken) -> Self {
        let run = shutdown.clone();
        Context { name, clock, shutdown, run }
    }

    /// The same context, able to end the whole run through `run` (the runtime's root token).
    pub fn with_run(mut self, run: CancellationToken) -> Self {
        self.run = run;
        self
    }

    /// The actor's name in the config.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The graph clock.
    pub fn clock(&self) -> &Arc<dyn Clock> {
        &self.clock
    }

    /// Now, on the graph clock.
    pub fn now(&self) -> Time {
        self.clock.now()
    }

    /// Cancelled when this incarnation must stop (shutdown or restart); tasks an actor spawns
    /// for its I/O should end with it.
    pub fn shutdown(&self) -> &CancellationToken {
        &self.shutdown
    }

    /// Ends this actor normally, its work done: it stops after the handler returns, and its
    /// supervisor restarts it only if its restart policy is `permanent`.
    pub fn stop(&self) {
        self.shutdown.cancel();
    }

    /// Ends the whole run, as Ctrl-C would: every actor stops and the log is closed. For a
    /// scripted flight that is over (`kestrel run --exit-on-land`).
    pub fn end_run(&self) {
        self.run.cancel();
    }
}

/// Why an actor could not go on. The supervisor logs it and restarts the actor as its restart
/// policy says, except after [`ActorError::Params`], which a restart cannot mend.
#[derive(Debug, thiserror::Error)]
pub enum ActorError {
    /// The actor's parameters are unusable; restarting will not help, so the runtime reports
    /// this at start-up.
    #[error("invalid parameters: {0}")]
    Params(String),
    /// A file or device could not be used.
    #[error("{what}: {source}")]
    Io {
        what: String,
        #[source]
        source: std::io::Error,
    },
    /// Any other failure, described for a person.
    #[error("{0}")]
    Failed(String),
}

/// A subsystem of the vehicle.
pub trait Actor: Send + Sized + 'static {
    /// The actor's parameters, from its `[actors.NAME.params]` table in the config.
    type Params: serde::de::DeserializeOwned + Send + Sync + 'static;

    /// Everything the actor handles: one variant per input port and timer.
    type Input: Send + 'static;

    /// Builds a fresh actor and declares its ports. Called at start-up and after each restart.
    fn build(params: &Self::Params, setup: &mut impl Setup<Self::Input>) -> Result<Self, ActorError>;

    /// Called once before the first input.
    fn start(&mut self, _ctx: &Context) -> impl Future<Output = Result<(), ActorError>> + Send {
        async { Ok(()) }
    }

    /// Handles one input. An error stops this incarnation; the supervisor decides what follows.
    fn handle(
        &mut self,
        ctx: &Context,
        input: Self::Input,
    ) -> impl Future<Output = Result<(), ActorError>> + Send;

    /// Called once on shutdown or before a restart, after the last input.
    fn stop(&mut self, _ctx: &Context) -> impl Future<Output = ()> + Send {
        async {}
    }
}
