//! The router: turns the config into topics and mailboxes and checks, before anything runs,
//! that every route names a real port and a real topic of the right message type.

use std::any::Any;
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use kestrel_proto::{ActorError, Clock, Keepsake, Message, Publisher, Setup, Time};

use crate::activity::{Activity, Busy};
use crate::config::{ActorDecl, ConfigError, Source};
use crate::mailbox::{Doorbell, Mailbox, MailboxKind, MailboxView};
use crate::recorder::{Recorder, RecorderError};
use crate::topic::Topic;

/// Starts recording a topic (the topic's type is captured inside).
type AttachRecorder = Box<dyn Fn(&Recorder) -> Result<(), RecorderError> + Send>;

/// A topic while the graph is wired, with the facts needed to check and report it.
struct TopicSlot {
    type_name: &'static str,
    topic: Arc<dyn Any + Send + Sync>,
    publishers: Vec<String>,
    /// `actor.port` and the config line of each subscription.
    subscribers: Vec<(String, usize)>,
    freeze: Box<dyn Fn() + Send>,
    record: AttachRecorder,
    published: Arc<dyn Fn() -> u64 + Send + Sync>,
}

/// The port on which an actor takes changes to its live parameters (a ground station's
/// PARAM_SET through the link's output of the same name).
pub const PARAM_SET_PORT: &str = "param_set";
/// The port on which an actor declares its live parameters (name, value, range) to the link.
pub const PARAM_DECL_PORT: &str = "param_decl";

/// Every topic of the graph, by name.
pub struct Graph {
    clock: Arc<dyn Clock>,
    activity: Arc<Activity>,
    topics: BTreeMap<String, TopicSlot>,
    mailboxes: Vec<Arc<dyn MailboxView>>,
    /// `actor.port` of each input an actor declared and the config left unrouted.
    unrouted_inputs: Vec<(String, &'static str)>,
    /// The devices the graph's drivers claimed ([`Setup::claim_device`]).
    device_locks: Vec<crate::locks::Lock>,
}

/// One topic's wiring: `actor.port` of each publisher and each subscriber ("runtime" for a
/// publisher the runtime itself holds).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TopicWiring {
    pub name: String,
    pub type_name: &'static str,
    pub publishers: Vec<String>,
    pub subscribers: Vec<String>,
}

/// What a topic looks like once the graph is wired, for status lines and reports.
#[derive(Clone)]
pub struct TopicHandle {
    pub name: String,
    pub type_name: &'static str,
    published: Arc<dyn Fn() -> u64 + Send + Sync>,
}

impl TopicHandle {
    /// Messages published on the topic so far.
    pub fn published(&self) -> u64 {
        (self.published)()
    }
}

impl Graph {
    /// An empty graph on `clock`.
    pub fn new(clock: Arc<dyn Clock>, activity: Arc<Activity>) -> Graph {
        Graph {
            clock,
            activity,
            topics: BTreeMap::new(),
            mailboxes: Vec::new(),
            unrouted_inputs: Vec::new(),
            device_locks: Vec::new(),
        }
    }

    /// The graph's clock.
    pub fn clock(&self) -> &Arc<dyn Clock> {
        &self.clock
    }

    /// The graph's work counter.
    pub fn activity(&self) -> &Arc<Activity> {
        &self.activity
    }

    /// The topic `name` of type `T`, created on first use; `Err` names the type it already has.
    pub fn topic<T: Message>(&mut self, name: &str) -> Result<Arc<Topic<T>>, &'static str> {
        let slot = self.topics.entry(name.to_owned()).or_insert_with(|| {
            let topic = Topic::<T>::new(name, Arc::clone(&self.clock));
            TopicSlot {
                type_name: T::TYPE_NAME,
                topic: Arc::clone(&topic) as Arc<dyn Any + Send + Sync>,
                publishers: Vec::new(),
                subscribers: Vec::new(),
                freeze: Box::new({
                    let topic = Arc::clone(&topic);
                    move || topic.freeze()
                }),
                record: Box::new({
                    let topic = Arc::clone(&topic);
                    move |recorder: &Recorder| {
                        topic.record_to(recorder.channel::<T>(topic.name())?);
                        Ok(())
                    }
                }),
                published: Arc::new(move || topic.published()),
            }
        });
        Arc::clone(&slot.topic).downcast::<Topic<T>>().map_err(|_| slot.type_name)
    }

    /// Whether a topic `name` of message type `type_name` has a publisher.
    pub fn is_published(&self, name: &str, type_name: &str) -> bool {
        self.topics.get(name).is_some_and(|s| s.type_name == type_name && !s.publishers.is_empty())
    }

    /// The device locks the drivers took while they were built, for the run to hold until it
    /// ends.
    pub fn take_device_locks(&mut self) -> Vec<crate::locks::Lock> {
        std::mem::take(&mut self.device_locks)
    }

    /// Who publishes and who reads each topic, in topic-name order: the wiring a config made,
    /// for drawing it (`crate::graph_drawing`).
    pub fn topic_wiring(&self) -> Vec<TopicWiring> {
        self.topics
            .iter()
            .map(|(name, slot)| TopicWiring {
                name: name.clone(),
                type_name: slot.type_name,
                publishers: slot.publishers.clone(),
                subscribers: slot.subscribers.iter().map(|(port, _)| port.clone()).collect(),
            })
            .collect()
    }

    /// Whether some actor reads topic `name` carrying `type_name`.
    pub fn is_subscribed(&self, name: &str, type_name: &str) -> bool {
        self.topics.get(name).is_some_and(|s| s.type_name == type_name && !s.subscribers.is_empty())
    }

    /// In a graph with a ground-station link (a publisher of `param_set`), every live parameter
    /// left out of it: an actor's `param_set` input not routed, or a `param_decl` output that no
    /// link subscribes to (another reader, such as the calibration, does not serve a ground
    /// station). Each names the actor and the port; empty when all are wired or the graph has no
    /// link (a bench with nothing to tune).
    pub fn unwired_parameters(&self) -> Vec<String> {
        let split = |endpoint: &str| {
            endpoint.rsplit_once('.').map(|(actor, port)| (actor.to_owned(), port.to_owned()))
        };
        let links: Vec<String> = self
            .topics
            .values()
            .flat_map(|s| s.publishers.iter().filter_map(|p| split(p)))
            .filter(|(_, port)| port == PARAM_SET_PORT)
            .map(|(actor, _)| actor)
            .collect();
        if links.is_empty() {
            return Vec::new();
        }
        let unset =
            self.unrouted_inputs.iter().filter(|(_, port)| *port == PARAM_SET_PORT).map(|(actor, port)| {
                format!(
                    "actor '{actor}' takes live parameters on input '{port}', which the config does not route"
                )
            });
        let read_by_a_link = |subscribers: &[(String, usize)]| {
            subscribers.iter().any(|(endpoint, _)| {
                split(endpoint).is_some_and(|(actor, port)| port == PARAM_DECL_PORT && links.contains(&actor))
            })
        };
        let undeclared =
            self.topics.iter().filter(|(_, s)| !read_by_a_link(&s.subscribers)).flat_map(|(topic, s)| {
                s.publishers.iter().filter(|p| split(p).is_some_and(|(_, port)| port == PARAM_DECL_PORT)).map(
                    move |p| {
                        format!("output '{p}' declares live parameters on topic '{topic}', which no link subscribes to (the link's inputs.{PARAM_DECL_PORT})")
                    },
                )
            });
        unset.chain(undeclared).collect()
    }

    /// Every actor mailbox of the graph, for reports.
    pub fn mailboxes(&self) -> Vec<Arc<dyn MailboxView>> {
        self.mailboxes.clone()
    }

    /// A publisher on topic `name`, for the runtime's own outputs (the supervisor's reports).
    pub fn runtime_publisher<T: Message>(&mut self, name: &str) -> Result<Publisher<T>, String> {
        let topic = self
            .topic::<T>(name)
            .map_err(|other| format!("topic '{name}' carries {other}, not {}", T::TYPE_NAME))?;
        if let Some(slot) = self.topics.get_mut(name) {
            slot.publishers.push("runtime".into());
        }
        Ok(Publisher::new(topic))
    }

    /// Subscribes an observer outside the graph (status line, tests) to `name`, if it exists
    /// with type `T`; its unread messages never hold the lockstep clock.
    pub fn observe<T: Message>(&mut self, name: &str, doorbell: Arc<Doorbell>) -> Option<Arc<Mailbox<T>>> {
        self.observe_as(name, MailboxKind::Latest, doorbell)
    }

    /// [`Graph::observe`] with a mailbox of `kind`: a queue where no message may be missed.
    pub fn observe_as<T: Message>(
        &mut self,
        name: &str,
        kind: MailboxKind,
        doorbell: Arc<Doorbell>,
    ) -> Option<Arc<Mailbox<T>>> {
        if self.topics.get(name)?.type_name != T::TYPE_NAME {
            return None;
        }
        let topic = self.topic::<T>(name).ok()?;
        let mailbox = Mailbox::observer(format!("{name} → observer"), kind, doorbell);
        topic.subscribe(Arc::clone(&mailbox));
        Some(mailbox)
    }

    /// Checks that every subscribed topic has a publisher and that every recorded topic
    /// exists, attaches the recorder, and fixes the wiring.
    pub fn finish(
        &mut self,
        source: &Source,
        record: Option<(&Recorder, &[toml::Spanned<String>])>,
    ) -> Result<Vec<TopicHandle>, ConfigError> {
        for (name, slot) in &self.topics {
            if slot.publishers.is_empty() {
                let (port, line) = &slot.subscribers[0];
                let known: Vec<&str> = self
                    .topics
                    .iter()
                    .filter(|(_, s)| !s.publishers.is_empty())
                    .map(|(n, _)| n.as_str())
                    .collect();
                return Err(source.error_on_line(
                    Some(*line),
                    format!(
                        "unknown topic '{name}' (subscribed by {port}): no running actor publishes it; topics: {}",
                        known.join(", ")
                    ),
                ));
            }
        }
        if let Some((recorder, topics)) = record {
            let everything = topics.iter().any(|t| t.get_ref() == "*");
            for wanted in topics.iter().filter(|t| t.get_ref() != "*") {
                if !self.topics.contains_key(wanted.get_ref()) {
                    return Err(source.error_at(
                        wanted.span(),
                        format!("[record] names unknown topic '{}'", wanted.get_ref()),
                    ));
                }
            }
            for (name, slot) in &self.topics {
                if everything || topics.iter().any(|t| t.get_ref() == name) {
                    (slot.record)(recorder)
                        .map_err(|e| source.error(format!("recording topic '{name}': {e}")))?;
                }
            }
        }
        for slot in self.topics.values() {
            (slot.freeze)();
        }
        Ok(self
            .topics
            .iter()
            .map(|(name, slot)| TopicHandle {
                name: name.clone(),
                type_name: slot.type_name,
                published: Arc::clone(&slot.published),
            })
            .collect())
    }
}

/// One input of a running actor: a mailbox and the conversion into the actor's input type.
pub trait InputPort<I>: Send + Sync {
    /// Arrival number of the oldest waiting message.
    fn oldest_arrival(&self) -> Option<u64>;
    /// Takes the oldest waiting message, converted, with its work token.
    fn take(&self) -> Option<(I, Option<Busy>)>;
    /// The actor is down: waiting messages stop counting as work (see [`Mailbox::park`]).
    fn park(&self);
    /// The actor is back.
    fn unpark(&self);
}

struct BoundInput<T, I> {
    mailbox: Arc<Mailbox<T>>,
    wrap: fn(T) -> I,
}

impl<T: Send, I: Send> InputPort<I> for BoundInput<T, I> {
    fn oldest_arrival(&self) -> Option<u64> {
        self.mailbox.oldest_arrival()
    }

    fn take(&self) -> Option<(I, Option<Busy>)> {
        self.mailbox.take().map(|(m, busy)| ((self.wrap)(m), busy))
    }

    fn park(&self) {
        self.mailbox.park();
    }

    fn unpark(&self) {
        self.mailbox.unpark();
    }
}

/// A periodic timer of a running actor.
pub struct TimerSpec {
    pub mailbox: Arc<Mailbox<Time>>,
    pub period: Duration,
}

/// An actor's ports, kept across restarts so that a restarted actor gets the same topics and
/// mailboxes (and messages published while it was down are waiting for it).
#[derive(Default)]
pub struct PortTable {
    ports: HashMap<&'static str, (PortKind, Arc<dyn Any + Send + Sync>)>,
    /// The actor's keepsakes by name: the table outlives incarnations, so they do too.
    keepsakes: HashMap<&'static str, Arc<dyn Any + Send + Sync>>,
}

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum PortKind {
    Output,
    Input,
    Timer,
}

/// The ports one build of an actor declared.
pub struct Declared<I> {
    pub inputs: Vec<Arc<dyn InputPort<I>>>,
    pub timers: Vec<TimerSpec>,
}

/// The [`Setup`] an actor is built with: at start-up it creates topics and mailboxes in the
/// graph; on a restart (no graph) it hands back the ones in the actor's [`PortTable`].
pub struct Wiring<'a, I> {
    name: &'a str,
    config_dir: &'a Path,
    clock: Arc<dyn Clock>,
    activity: Arc<Activity>,
    doorbell: Arc<Doorbell>,
    table: &'a mut PortTable,
    first: Option<FirstBuild<'a>>,
    declared: Declared<I>,
    names: BTreeSet<&'static str>,
    errors: Vec<String>,
}

struct FirstBuild<'a> {
    graph: &'a mut Graph,
    decl: &'a ActorDecl,
    source: &'a Source,
    located: Vec<ConfigError>,
}

impl<'a, I: Send + 'static> Wiring<'a, I> {
    /// Wiring for an actor's first build, creating its topics and mailboxes in `graph`.
    pub fn first(
        name: &'a str,
        decl: &'a ActorDecl,
        source: &'a Source,
        graph: &'a mut Graph,
        table: &'a mut PortTable,
        doorbell: Arc<Doorbell>,
    ) -> Self {
        Wiring {
            name,
            config_dir: source.dir(),
            clock: Arc::clone(graph.clock()),
            activity: Arc::clone(graph.activity()),
            doorbell,
            table,
            first: Some(FirstBuild { graph, decl, source, located: Vec::new() }),
            declared: Declared { inputs: Vec::new(), timers: Vec::new() },
            names: BTreeSet::new(),
            errors: Vec::new(),
        }
    }

    /// Wiring for a restart, reusing the ports in `table`.
    pub fn rebuild(
        name: &'a str,
        config_dir: &'a Path,
        clock: Arc<dyn Clock>,
        activity: Arc<Activity>,
        doorbell: Arc<Doorbell>,
        table: &'a mut PortTable,
    ) -> Self {
        Wiring {
            name,
            config_dir,
            clock,
            activity,
            doorbell,
            table,
            first: None,
            declared: Declared { inputs: Vec::new(), timers: Vec::new() },
            names: BTreeSet::new(),
            errors: Vec::new(),
        }
    }

    /// The declared ports, or every wiring error found. On a first build this also checks
    /// that each port the config routes was declared by the actor.
    pub fn finish(self) -> Result<Declared<I>, Vec<ConfigError>> {
        let mut errors = Vec::new();
        if let Some(first) = self.first {
            errors = first.located;
            let check =
                |ports: Vec<&toml::Spanned<String>>, kind: PortKind, errors: &mut Vec<ConfigError>| {
                    for port in ports {
                        let found = self.table.ports.get(port.get_ref().as_str()).map(|(k, _)| *k);
                        if found != Some(kind) {
                            let mut known: Vec<&str> = self
                                .table
                                .ports
                                .iter()
                                .filter(|(_, (k, _))| *k == kind)
                                .map(|(n, _)| *n)
                                .collect();
                            known.sort_unstable();
                            let what = if kind == PortKind::Output { "output" } else { "input" };
                            errors.push(first.source.error_at(
                                port.span(),
                                format!(
                                    "actor '{}' has no {what} port '{}'; its {what}s: {}",
                                    self.name,
                                    port.get_ref(),
                                    if known.is_empty() { "none".to_owned() } else { known.join(", ") }
                                ),
                            ));
                        }
                    }
                };
            check(first.decl.inputs.keys().collect(), PortKind::Input, &mut errors);
            check(first.decl.outputs.keys().collect(), PortKind::Output, &mut errors);
        }
        let source_less = self.errors.into_iter().map(|message| ConfigError {
            file: std::path::PathBuf::new(),
            line: None,
            message,
        });
        errors.extend(source_less);
        if errors.is_empty() { Ok(self.declared) } else { Err(errors) }
    }

    fn claim(&mut self, port: &'static str) -> bool {
        if self.names.insert(port) {
            return true;
        }
        self.errors.push(format!("actor '{}' declares port '{port}' twice", self.name));
        false
    }

    fn stored<P: Any + Send + Sync>(&mut self, port: &'static str, kind: PortKind) -> Option<Arc<P>> {
        match self.table.ports.get(port) {
            Some((k, any)) if *k == kind => match Arc::clone(any).downcast::<P>() {
                Ok(p) => Some(p),
                Err(_) => {
                    self.errors
                        .push(format!("actor '{}' changed the type of port '{port}' on restart", self.name));
                    None
                }
            },
            Some(_) => {
                self.errors
                    .push(format!("actor '{}' changed the kind of port '{port}' on restart", self.name));
                None
            }
            None => {
                self.errors.push(format!("actor '{}' declared a new port '{port}' on restart", self.name));
                None
            }
        }
    }
}

impl<I: Send + 'static> Setup<I> for Wiring<'_, I> {
    fn name(&self) -> &str {
        self.name
    }

    fn config_dir(&self) -> &Path {
        self.config_dir
    }

    fn clock(&self) -> Arc<dyn Clock> {
        Arc::clone(&self.clock)
    }

    fn output<T: Message>(&mut self, port: &'static str) -> Publisher<T> {
        self.claim(port);
        let publisher = match self.first.as_mut() {
            Some(first) => {
                let renamed = first.decl.outputs.iter().find(|(p, _)| p.get_ref() == port).map(|(_, t)| t);
                let topic_name = renamed.map_or(port, |t| t.get_ref().as_str());
                match first.graph.topic::<T>(topic_name) {
                    Ok(topic) => {
                        if let Some(slot) = first.graph.topics.get_mut(topic_name) {
                            slot.publishers.push(format!("{}.{port}", self.name));
                        }
                        Publisher::new(topic)
                    }
                    Err(other) => {
                        let message = format!(
                            "type mismatch on topic '{topic_name}': actor '{}' output '{port}' publishes {}, but the topic carries {other}",
                            self.name,
                            T::TYPE_NAME
                        );
                        first.located.push(match renamed {
                            Some(t) => first.source.error_at(t.span(), message),
                            None => first.source.error(message),
                        });
                        // A detached topic keeps the build going so every error is reported.
                        Publisher::new(Topic::<T>::new(topic_name, Arc::clone(&self.clock)))
                    }
                }
            }
            None => match self.stored::<Publisher<T>>(port, PortKind::Output) {
                Some(p) => (*p).clone(),
                None => Publisher::new(Topic::<T>::new(port, Arc::clone(&self.clock))),
            },
        };
        if self.first.is_some() {
            self.table.ports.insert(port, (PortKind::Output, Arc::new(publisher.clone())));
        }
        publisher
    }

    fn input<T: Message>(&mut self, port: &'static str, wrap: fn(T) -> I) {
        self.claim(port);
        let mailbox: Option<Arc<Mailbox<T>>> = match self.first.as_mut() {
            Some(first) => {
                let route = first.decl.inputs.iter().find(|(p, _)| p.get_ref() == port).map(|(_, r)| r);
                let mailbox = route.and_then(|route| {
                    let kind: MailboxKind = route.mailbox.get_ref().parse().ok()?;
                    let topic_name = route.topic.get_ref();
                    let line = first.source.line_of(route.topic.span().start);
                    match first.graph.topic::<T>(topic_name) {
                        Ok(topic) => {
                            let mailbox = Mailbox::new(
                                format!("{topic_name} → {}.{port}", self.name),
                                kind,
                                Arc::clone(&self.doorbell),
                                Arc::clone(&self.activity),
                            );
                            topic.subscribe(Arc::clone(&mailbox));
                            first.graph.mailboxes.push(Arc::clone(&mailbox) as Arc<dyn MailboxView>);
                            if let Some(slot) = first.graph.topics.get_mut(topic_name.as_str()) {
                                slot.subscribers.push((format!("{}.{port}", self.name), line));
                            }
                            Some(mailbox)
                        }
                        Err(other) => {
                            first.located.push(first.source.error_at(
                                route.topic.span(),
                                format!(
                                    "type mismatch on topic '{topic_name}': actor '{}' input '{port}' takes {}, but the topic carries {other}",
                                    self.name,
                                    T::TYPE_NAME
                                ),
                            ));
                            None
                        }
                    }
                });
                if route.is_none() {
                    first.graph.unrouted_inputs.push((self.name.to_owned(), port));
                }
                self.table.ports.insert(port, (PortKind::Input, Arc::new(mailbox.clone())));
                mailbox
            }
            None => self.stored::<Option<Arc<Mailbox<T>>>>(port, PortKind::Input).and_then(|m| (*m).clone()),
        };
        if let Some(mailbox) = mailbox {
            self.declared.inputs.push(Arc::new(BoundInput { mailbox, wrap }));
        }
    }

    fn timer(&mut self, port: &'static str, period: Duration, tick: fn(Time) -> I) {
        self.claim(port);
        if period.is_zero() {
            self.errors.push(format!("actor '{}' timer '{port}' has a zero period", self.name));
            return;
        }
        let mailbox = if self.first.is_some() {
            let mailbox = Mailbox::new(
                format!("timer → {}.{port}", self.name),
                MailboxKind::Latest,
                Arc::clone(&self.doorbell),
                Arc::clone(&self.activity),
            );
            self.table
                .ports
                .insert(port, (PortKind::Timer, Arc::clone(&mailbox) as Arc<dyn Any + Send + Sync>));
            Some(mailbox)
        } else {
            self.stored::<Mailbox<Time>>(port, PortKind::Timer)
        };
        if let Some(mailbox) = mailbox {
            self.declared.inputs.push(Arc::new(BoundInput { mailbox: Arc::clone(&mailbox), wrap: tick }));
            self.declared.timers.push(TimerSpec { mailbox, period });
        }
    }

    fn claim_device(&mut self, device: &Path) -> Result<(), ActorError> {
        match self.first.as_mut() {
            Some(first) => crate::locks::claim_device(&mut first.graph.device_locks, device)
                .map_err(|e| ActorError::Failed(e.to_string())),
            // A restarted actor still holds its first build's claim.
            None => Ok(()),
        }
    }

    fn keepsake<T: Clone + Send + 'static>(&mut self, name: &'static str) -> Keepsake<T> {
        let stored = self.table.keepsakes.get(name).map(|any| Arc::clone(any).downcast::<Keepsake<T>>());
        match stored {
            Some(Ok(kept)) => (*kept).clone(),
            Some(Err(_)) => {
                self.errors
                    .push(format!("actor '{}' changed the type of keepsake '{name}' on restart", self.name));
                Keepsake::new()
            }
            None => {
                let kept = Keepsake::<T>::new();
                self.table.keepsakes.insert(name, Arc::new(kept.clone()));
                kept
            }
        }
    }
}
