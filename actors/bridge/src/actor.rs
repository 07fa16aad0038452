//! The bridge's actor shell: a Zenoh session that sends the graph's `publish` topics out and
//! publishes the network's `subscribe` topics into the graph.
//!
//! Inputs: one port per `publish` topic, named after it (the config routes it, with the mailbox
//! kind it wants: `latest` for states, a queue for commands). Outputs: one per `subscribe`
//! topic, named after it; a sample is decoded, moved onto the local clock and checked on
//! Zenoh's own thread, then published straight into the local topic, so local subscribers read
//! a remote topic through the same mailboxes as a local one.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use kestrel_proto::{Actor, ActorError, Clock, Context, Publisher, Setup};
use tokio::sync::mpsc;
use zenoh::bytes::Encoding;
use zenoh::sample::Sample;
use zenoh::time::{NTP64, Timestamp, TimestampId};
use zenoh::{Config, Session};

use crate::catalogue::{Bridged, TOPICS, TopicVisitor, visit_topic};
use crate::error::BridgeError;
use crate::hop_latency::HopLatency;
use crate::key_expr::topic_key;
use crate::params::BridgeParams;
use crate::payload::{self, ClockOrigin, Decoded, Outgoing, Received};
use crate::rate_limit::RateLimit;
use crate::sources::CommandSources;
use crate::zenoh_file;

/// Longest wait between two tries of a `connect` endpoint that does not answer (Zenoh's default
/// backs off to 4 s): the other side of a split is back within a second of its restart.
const CONNECT_RETRY_MAX_MS: u32 = 1000;

/// Decode failures logged one by one before the bridge logs only every this many.
const LOGGED_FAILURES: u64 = 10;

/// Whether the `n`-th failure of a kind is logged: the first few, then every hundredth, so a
/// flood of bad samples cannot flood the log.
fn worth_logging(n: u64) -> bool {
    n <= LOGGED_FAILURES || n.is_multiple_of(100)
}

/// What the bridge handles.
pub enum BridgeInput {
    /// A local message to send, serialised (or why it could not be).
    Outgoing(Result<Outgoing, String>),
}

fn outgoing<T: Bridged>(msg: T) -> BridgeInput {
    BridgeInput::Outgoing(payload::encode(&msg))
}

/// Receives one topic from the network.
type Inbound = Arc<dyn Fn(Sample) + Send + Sync>;

/// Per-topic figures of the samples the bridge received.
#[derive(Default)]
struct InboundStats {
    hop: HopLatency,
    refused: u64,
    /// Samples of a motor topic from a source `command_sources` does not list.
    unlisted: u64,
    /// Samples with a time after the host clock, clamped to it, and the furthest ahead (µs).
    clamped: u64,
    max_ahead_us: u64,
}

/// The Zenoh bridge.
pub struct BridgeActor {
    params: BridgeParams,
    /// The Zenoh config file's settings (authentication, access control), or Zenoh's defaults.
    base_config: Config,
    vehicle: String,
    /// The `subscribe` topics with what receives each.
    inbound: Vec<(&'static str, Inbound)>,
    stats: BTreeMap<&'static str, Arc<Mutex<InboundStats>>>,
    network: Option<Network>,
    send_failures: u64,
    /// The `max_rate_hz` topics, and how many messages each limit dropped.
    limits: BTreeMap<&'static str, (RateLimit, u64)>,
}

/// The bridge's side of Zenoh: a runtime of its own with one task that owns the session.
/// Zenoh refuses tokio's current-thread scheduler, which a lockstep graph runs on, and the
/// actor never waits on the network: it hands messages over a bounded queue.
struct Network {
    /// Dropped last, after the task's handle.
    _runtime: OwnRuntime,
    /// Dropped to end the task.
    outgoing: Option<mpsc::Sender<Outgoing>>,
    task: tokio::task::JoinHandle<()>,
}

/// The bridge's runtime, shut down without waiting when dropped: a plain drop blocks, which
/// tokio forbids inside the graph's runtime, where an actor is dropped.
struct OwnRuntime(Option<tokio::runtime::Runtime>);

impl Drop for OwnRuntime {
    fn drop(&mut self) {
        if let Some(runtime) = self.0.take() {
            runtime.shutdown_background();
        }
    }
}

impl OwnRuntime {
    fn new() -> std::io::Result<OwnRuntime> {
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .thread_name("zenoh-bridge")
            .enable_all()
            .build()?;
        Ok(OwnRuntime(Some(runtime)))
    }

    fn handle(&self) -> Option<&tokio::runtime::Runtime> {
        self.0.as_ref()
    }
}

/// Messages waiting for the network task; more are dropped and counted (a stalled link must
/// not grow memory or hold the actor).
const OUTGOING_QUEUE: usize = 256;

/// How long `stop` waits for the session to close.
const CLOSE_TIMEOUT: Duration = Duration::from_secs(2);

/// Now on the UNIX wall clock (µs). The bridge is the one actor that reads it: both ends of a
/// hop share only the wall clock, not their graph clocks.
fn unix_now_us() -> i64 {
    let since = SystemTime::now().duration_since(UNIX_EPOCH).unwrap_or(Duration::ZERO);
    i64::try_from(since.as_micros()).unwrap_or(i64::MAX)
}

fn unix_us_of(ntp: &NTP64) -> i64 {
    i64::try_from(ntp.to_duration().as_micros()).unwrap_or(i64::MAX)
}

fn ntp_of(unix_us: i64) -> NTP64 {
    NTP64::from(Duration::from_micros(u64::try_from(unix_us).unwrap_or(0)))
}

struct DeclareInputs<'a, S> {
    setup: &'a mut S,
}

impl<S: Setup<BridgeInput>> TopicVisitor for DeclareInputs<'_, S> {
    fn visit<T: Bridged>(&mut self, topic: &'static str) {
        self.setup.input::<T>(topic, outgoing::<T>);
    }
}

struct DeclareOutputs<'a, S> {
    setup: &'a mut S,
    clock: Arc<dyn Clock>,
    key: String,
    sources: CommandSources,
    made: Option<(Inbound, Arc<Mutex<InboundStats>>)>,
}

impl<S: Setup<BridgeInput>> TopicVisitor for DeclareOutputs<'_, S> {
    fn visit<T: Bridged>(&mut self, topic: &'static str) {
        let publisher: Publisher<T> = self.setup.output::<T>(topic);
        let stats = Arc::new(Mutex::new(InboundStats::default()));
        let (clock, key, kept) = (Arc::clone(&self.clock), self.key.clone(), Arc::clone(&stats));
        let sources = self.sources.clone();
        let inbound = move |sample: Sample| {
            let arrived_unix_us = unix_now_us();
            if T::MOVES_MOTORS {
                let sender = sample.timestamp().map(|ts| u128::from_le_bytes(ts.get_id().to_le_bytes()));
                if let Err(why) = sources.admit(sender) {
                    let mut stats = kept.lock().unwrap_or_else(PoisonError::into_inner);
                    stats.unlisted += 1;
                    if worth_logging(stats.unlisted) {
                        tracing::warn!(unlisted = stats.unlisted, "bridge refused a sample on {key}: {why}");
                    }
                    return;
                }
            }
            let now = clock.now();
            let encoding = sample.encoding().to_string();
            let payload = sample.payload().to_bytes();
            let received = Received {
                key: &key,
                encoding: &encoding,
                payload: &payload,
                captured_unix_us: sample.timestamp().map(|ts| unix_us_of(ts.get_time())),
            };
            let decoded = payload::decode::<T>(received, ClockOrigin::at(now, arrived_unix_us), now);
            let mut stats = kept.lock().unwrap_or_else(PoisonError::into_inner);
            match decoded {
                Ok(Decoded { msg, clamped_by_us }) => {
                    if clamped_by_us > 0 {
                        stats.clamped += 1;
                        stats.max_ahead_us = stats.max_ahead_us.max(clamped_by_us);
                        if worth_logging(stats.clamped) {
                            tracing::warn!(
                                clamped = stats.clamped,
                                "bridge clamped a time {:.3} s in the future to now on {key}",
                                clamped_by_us as f64 / 1e6
                            );
                        }
                    }
                    if let Some(sent) =
                        sample.attachment().and_then(|a| payload::read_sent_attachment(&a.to_bytes()))
                    {
                        stats.hop.record(sent, arrived_unix_us);
                    }
                    drop(stats);
                    publisher.publish(msg);
                }
                Err(e) => {
                    stats.refused += 1;
                    if worth_logging(stats.refused) {
                        tracing::warn!(refused = stats.refused, "bridge refused a sample: {e}");
                    }
                }
            }
        };
        self.made = Some((Arc::new(inbound), stats));
    }
}

/// `base` (the Zenoh config file's settings) with the graph's: mode, endpoints, scouting.
fn zenoh_config(p: &BridgeParams, base: Config) -> Result<Config, String> {
    let json = |v: &[String]| serde_json::to_string(v).unwrap_or_default();
    let mut config = base;
    let listen = p.listen_endpoints().map_err(|e| e.to_string())?;
    let settings = [
        ("mode", format!("\"{}\"", p.mode.zenoh_name())),
        ("connect/endpoints", json(&p.connect)),
        ("listen/endpoints", json(&listen)),
        ("scouting/multicast/enabled", p.scouting.to_string()),
        (
            "connect/retry",
            format!(
                "{{ period_init_ms: {}, period_max_ms: {CONNECT_RETRY_MAX_MS}, period_increase_factor: 2 }}",
                CONNECT_RETRY_MAX_MS / 4
            ),
        ),
    ];
    for (key, value) in settings {
        config.insert_json5(key, &value).map_err(|e| format!("zenoh config {key} = {value}: {e}"))?;
    }
    Ok(config)
}

/// Opens the session and declares the bridge's publishers and subscribers.
async fn open(
    config: Config,
    vehicle: &str,
    publish: &[&'static str],
    inbound: &[(&'static str, Inbound)],
) -> Result<
    (Session, BTreeMap<&'static str, zenoh::pubsub::Publisher<'static>>, Vec<zenoh::pubsub::Subscriber<()>>),
    String,
> {
    let session = zenoh::open(config).await.map_err(|e| format!("opening the zenoh session: {e}"))?;
    let mut publishers = BTreeMap::new();
    for &topic in publish {
        let key = topic_key(vehicle, topic).map_err(|e| e.to_string())?;
        // Express: sent at once, never batched with the next message (latency over throughput);
        // a full link drops (Zenoh's default for puts), it never blocks.
        let publisher = session
            .declare_publisher(key.clone())
            .express(true)
            .await
            .map_err(|e| format!("declaring publisher {key}: {e}"))?;
        publishers.insert(topic, publisher);
    }
    let mut subscribers = Vec::new();
    for (topic, inbound) in inbound {
        let key = topic_key(vehicle, topic).map_err(|e| e.to_string())?;
        let inbound = Arc::clone(inbound);
        let subscriber = session
            .declare_subscriber(key.clone())
            .callback(move |sample| inbound(sample))
            .await
            .map_err(|e| format!("declaring subscriber {key}: {e}"))?;
        subscribers.push(subscriber);
    }
    Ok((session, publishers, subscribers))
}

/// The network task: sends what the actor hands over until the actor lets go, then closes.
async fn serve(
    session: Session,
    publishers: BTreeMap<&'static str, zenoh::pubsub::Publisher<'static>>,
    subscribers: Vec<zenoh::pubsub::Subscriber<()>>,
    mut outgoing: mpsc::Receiver<Outgoing>,
) {
    let id: TimestampId = *session.new_timestamp().get_id();
    let mut failures = 0u64;
    while let Some(out) = outgoing.recv().await {
        let Some(publisher) = publishers.get(out.topic) else { continue };
        let sent_unix_us = unix_now_us();
        let put = publisher
            .put(out.json)
            .encoding(Encoding::APPLICATION_JSON.with_schema(out.schema))
            .timestamp(Timestamp::new(ntp_of(out.captured_unix_us), id))
            .attachment(payload::sent_attachment(sent_unix_us).to_vec())
            .await;
        if let Err(e) = put {
            failures += 1;
            if worth_logging(failures) {
                tracing::warn!(failures, "bridge send on {}: {e}", out.topic);
            }
        }
    }
    drop(subscribers);
    drop(publishers);
    if let Err(e) = session.close().await {
        tracing::warn!("closing the zenoh session: {e}");
    }
}

impl Actor for BridgeActor {
    type Params = BridgeParams;
    type Input = BridgeInput;

    fn build(params: &BridgeParams, setup: &mut impl Setup<BridgeInput>) -> Result<Self, ActorError> {
        params.check().map_err(|e| ActorError::Params(e.to_string()))?;
        let sources =
            CommandSources::parse(&params.command_sources).map_err(|e| ActorError::Params(e.to_string()))?;
        let base_config = match &params.zenoh_config {
            Some(path) => {
                let file = zenoh_file::load(setup.config_dir(), path)
                    .map_err(|e| ActorError::Params(e.to_string()))?;
                if let Some(topic) = params.motor_topics().first()
                    && !file.denies_by_default
                {
                    return Err(ActorError::Params(
                        BridgeError::ZenohConfig {
                            file: file.path,
                            field: "access_control".into(),
                            why: format!(
                                "the bridge subscribes to '{topic}', which moves the motors: access control \
                                 must be enabled with default_permission \"deny\""
                            ),
                        }
                        .to_string(),
                    ));
                }
                for warning in &file.warnings {
                    tracing::warn!("{warning}");
                }
                file.config
            }
            None => Config::default(),
        };
        let vehicle = params.vehicle_name();
        for topic in &params.publish {
            visit_topic(topic, &mut DeclareInputs { setup: &mut *setup });
        }
        let mut inbound = Vec::new();
        let mut stats = BTreeMap::new();
        for topic in &params.subscribe {
            let key = topic_key(&vehicle, topic).map_err(|e| ActorError::Params(e.to_string()))?;
            let clock = setup.clock();
            let mut declare =
                DeclareOutputs { setup: &mut *setup, clock, key, sources: sources.clone(), made: None };
            visit_topic(topic, &mut declare);
            let Some(&name) = TOPICS.iter().find(|t| *t == topic) else { continue };
            if let Some((handler, topic_stats)) = declare.made {
                inbound.push((name, handler));
                stats.insert(name, topic_stats);
            }
        }
        let limits = TOPICS
            .iter()
            .filter_map(|&t| params.max_rate_hz.get(t).map(|&hz| (t, (RateLimit::new(hz), 0))))
            .collect();
        Ok(BridgeActor {
            params: params.clone(),
            base_config,
            vehicle,
            inbound,
            stats,
            network: None,
            send_failures: 0,
            limits,
        })
    }

    async fn start(&mut self, ctx: &Context) -> Result<(), ActorError> {
        let config = zenoh_config(&self.params, self.base_config.clone()).map_err(ActorError::Params)?;
        let own = OwnRuntime::new()
            .map_err(|source| ActorError::Io { what: "the zenoh bridge's runtime".into(), source })?;
        let runtime =
            own.handle().ok_or_else(|| ActorError::Failed("the zenoh bridge's runtime is gone".into()))?;
        let publish: Vec<&'static str> =
            TOPICS.iter().copied().filter(|t| self.params.publish.iter().any(|p| p == t)).collect();
        let (vehicle, inbound) = (self.vehicle.clone(), self.inbound.clone());
        let opened = runtime.spawn(async move { open(config, &vehicle, &publish, &inbound).await });
        let (session, publishers, subscribers) = opened
            .await
            .map_err(|e| ActorError::Failed(format!("the zenoh bridge's runtime: {e}")))?
            .map_err(ActorError::Failed)?;
        tracing::info!(
            actor = ctx.name(),
            vehicle = %self.vehicle,
            zid = %session.zid(),
            publish = ?self.params.publish,
            subscribe = ?self.params.subscribe,
            "zenoh bridge up"
        );
        let (tx, rx) = mpsc::channel(OUTGOING_QUEUE);
        let task = runtime.spawn(serve(session, publishers, subscribers, rx));
        self.network = Some(Network { outgoing: Some(tx), task, _runtime: own });
        Ok(())
    }

    async fn handle(&mut self, ctx: &Context, input: BridgeInput) -> Result<(), ActorError> {
        let BridgeInput::Outgoing(encoded) = input;
        let Some(outgoing) = self.network.as_ref().and_then(|n| n.outgoing.as_ref()) else { return Ok(()) };
        let mut out = match encoded {
            Ok(out) => out,
            Err(e) => {
                self.send_failures += 1;
                tracing::warn!(actor = ctx.name(), "bridge cannot send a message: {e}");
                return Ok(());
            }
        };
        if let Some((limit, dropped)) = self.limits.get_mut(out.topic)
            && !limit.admit(ctx.now())
        {
            *dropped += 1;
            return Ok(());
        }
        out.captured_unix_us = ClockOrigin::at(ctx.now(), unix_now_us()).to_unix_us(out.captured);
        match outgoing.try_send(out) {
            Ok(()) => Ok(()),
            Err(mpsc::error::TrySendError::Full(out)) => {
                self.send_failures += 1;
                if worth_logging(self.send_failures) {
                    tracing::warn!(
                        actor = ctx.name(),
                        failures = self.send_failures,
                        "bridge queue full: dropped a message on {}",
                        out.topic
                    );
                }
                Ok(())
            }
            Err(mpsc::error::TrySendError::Closed(_)) => {
                Err(ActorError::Failed("the zenoh bridge's network task ended".into()))
            }
        }
    }

    async fn stop(&mut self, ctx: &Context) {
        for (topic, stats) in &self.stats {
            let stats = stats.lock().unwrap_or_else(PoisonError::into_inner);
            let (p50, p95) = stats.hop.percentiles_ms().unwrap_or((f64::NAN, f64::NAN));
            tracing::info!(
                actor = ctx.name(),
                topic,
                received = stats.hop.received(),
                refused = stats.refused,
                unlisted_source = stats.unlisted,
                future_clamped = stats.clamped,
                max_ahead_s = stats.max_ahead_us as f64 / 1e6,
                "bridge hop latency p50 {p50:.3} ms p95 {p95:.3} ms"
            );
        }
        for (topic, (_, dropped)) in &self.limits {
            tracing::info!(
                actor = ctx.name(),
                topic,
                dropped,
                "bridge max_rate_hz dropped {dropped} messages"
            );
        }
        if let Some(mut network) = self.network.take() {
            network.outgoing = None;
            if tokio::time::timeout(CLOSE_TIMEOUT, &mut network.task).await.is_err() {
                tracing::warn!(
                    actor = ctx.name(),
                    "the zenoh session did not close within {CLOSE_TIMEOUT:?}"
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zenoh_takes_the_config_built_from_the_parameters() {
        let params: BridgeParams = toml::from_str(
            "vehicle = \"v\"\nmode = \"client\"\nconnect = [\"tcp/127.0.0.1:7447\", \"tcp/[::1]:7448\"]\nlisten = [\"tcp/0.0.0.0:7449\"]\npublish = [\"nav_state\"]",
        )
        .unwrap();
        let config = zenoh_config(&params, Config::default()).unwrap();
        let text = format!("{config}");
        for wanted in
            ["\"client\"", "tcp/127.0.0.1:7447", "tcp/[::1]:7448", "tcp/0.0.0.0:7449", "period_max_ms"]
        {
            assert!(text.contains(wanted), "{wanted} in {text}");
        }
    }
}
