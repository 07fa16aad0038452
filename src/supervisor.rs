//! One-for-one supervision: each actor runs in its own task; when it ends, only it is
//! restarted, as its restart policy says (Erlang's and kameo's vocabulary: `permanent` always,
//! `transient` after an error or a panic, `never`), after an exponential backoff, until it
//! fails more often than its restart limit allows within the window. An actor whose parameters
//! are invalid is never restarted: building it again from them fails again. Every failure is
//! published on the `supervisor` topic; a flight-critical actor's events also go to the
//! escalation hook, which the commander uses to trigger a failsafe.

use std::collections::VecDeque;
use std::marker::PhantomData;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use kestrel_proto::messages::{SupervisorEvent, SupervisorEventKind};
use kestrel_proto::realtime::{RealtimePriority, set_realtime_priority};
use kestrel_proto::{Actor, ActorError, Clock, Context, Publisher, Time};
use tokio::task::JoinHandle;
use tokio_util::sync::CancellationToken;

use crate::activity::{Activity, Busy};
use crate::config::{ActorDecl, ConfigError, Restart, RestartPolicy, Source};
use crate::fault_injection::PanicSchedule;
use crate::graph::{Declared, Graph, InputPort, PortTable, TimerSpec, Wiring};
use crate::mailbox::Doorbell;

/// Called with every event about a flight-critical actor.
pub type EscalationHook = Arc<dyn Fn(&SupervisorEvent) + Send + Sync>;

/// What the supervisor needs from the runtime.
#[derive(Clone)]
pub struct SupervisorContext {
    pub clock: Arc<dyn Clock>,
    pub activity: Arc<Activity>,
    pub shutdown: CancellationToken,
    pub events: Publisher<SupervisorEvent>,
    pub escalate: EscalationHook,
    /// Every event, for the run report.
    pub log: Arc<Mutex<Vec<SupervisorEvent>>>,
    /// The world file's `actor_panic` faults.
    pub panics: Arc<PanicSchedule>,
    /// Whether an actor's `priority` is honoured (the realtime clock): lockstep runs every
    /// actor on its one thread, which is what makes it deterministic.
    pub dedicated_threads: bool,
}

/// An actor type the config can name.
pub trait ActorKind: Send + Sync {
    /// Deserialises the parameters, builds the actor once and wires its ports into `graph`.
    fn prepare(
        &self,
        name: &str,
        decl: &ActorDecl,
        source: &Source,
        graph: &mut Graph,
    ) -> Result<Box<dyn Supervised>, Vec<ConfigError>>;
}

/// A prepared actor, ready to run under supervision.
pub trait Supervised: Send {
    /// Starts the supervision task.
    fn spawn(self: Box<Self>, ctx: SupervisorContext) -> JoinHandle<()>;
}

/// The [`ActorKind`] of actor type `A`.
pub struct KindOf<A>(PhantomData<fn() -> A>);

impl<A> Default for KindOf<A> {
    fn default() -> Self {
        KindOf(PhantomData)
    }
}

impl<A: Actor> ActorKind for KindOf<A> {
    fn prepare(
        &self,
        name: &str,
        decl: &ActorDecl,
        source: &Source,
        graph: &mut Graph,
    ) -> Result<Box<dyn Supervised>, Vec<ConfigError>> {
        let (table_value, params_at) = match &decl.params {
            Some(p) => (toml::Value::Table(p.get_ref().clone()), p.span()),
            None => (toml::Value::Table(toml::Table::new()), decl.kind.span()),
        };
        let at = |message: String| {
            let line = param_line(source, name, decl, &message)
                .or_else(|| (!params_at.is_empty()).then(|| source.line_of(params_at.start)));
            source.error_on_line(line, message)
        };
        let params: A::Params = table_value.try_into().map_err(|e: toml::de::Error| {
            vec![at(format!("actor '{name}' params: {}", e.message().trim()))]
        })?;
        let doorbell = Doorbell::new();
        let mut table = PortTable::default();
        let mut wiring = Wiring::first(name, decl, source, graph, &mut table, Arc::clone(&doorbell));
        let built = A::build(&params, &mut wiring);
        let declared = wiring.finish();
        let actor = built.map_err(|e| vec![at(format!("actor '{name}': {e}"))])?;
        let declared = declared.map_err(|errors| {
            errors
                .into_iter()
                .map(|e| if e.file.as_os_str().is_empty() { source.error(e.message) } else { e })
                .collect::<Vec<_>>()
        })?;
        Ok(Box::new(Prepared::<A> {
            name: Arc::from(name),
            critical: decl.critical,
            priority: decl.priority,
            policy: decl.restart.clone(),
            config_dir: source.dir().to_owned(),
            params,
            table,
            doorbell,
            first: Some((actor, declared)),
        }))
    }
}

/// The line of the parameter an error message names: the longest dotted key path of the
/// actor's `params` (`camera.width_px`, `tick_rate_hz`) that the message mentions as a whole
/// word, else a string value it quotes (`"127.0.0.1:99999"`), else a key name only one
/// parameter has. Parameters come to the actor without their places, so this is how an actor's
/// "field X is out of range" finds its line; `None` when the message names none that the file
/// spells. Array elements are path segments `0`, `1`, ….
fn param_line(source: &Source, name: &str, decl: &ActorDecl, message: &str) -> Option<usize> {
    type Leaf = (Vec<String>, Option<String>);
    fn paths(value: &toml::Value, prefix: &[String], out: &mut Vec<Leaf>) {
        let children: Vec<(String, &toml::Value)> = match value {
            toml::Value::Table(table) => table.iter().map(|(k, v)| (k.clone(), v)).collect(),
            toml::Value::Array(items) => items.iter().enumerate().map(|(i, v)| (i.to_string(), v)).collect(),
            _ => Vec::new(),
        };
        for (key, child) in children {
            let mut path = prefix.to_vec();
            path.push(key);
            paths(child, &path, out);
            out.push((path, child.as_str().map(str::to_owned)));
        }
    }
    let mentions = |word: &str| {
        message.match_indices(word).any(|(i, _)| {
            let ident = |c: char| c.is_alphanumeric() || c == '_' || c == '.';
            !message[..i].ends_with(ident) && !message[i + word.len()..].starts_with(ident)
        })
    };
    let mut all = Vec::new();
    paths(&toml::Value::Table(decl.params.as_ref()?.get_ref().clone()), &[], &mut all);
    all.sort_by_key(|(p, _)| std::cmp::Reverse(p.join(".").len()));
    let last = |p: &[String]| p.last().cloned().unwrap_or_default();
    let unique_last = |p: &[String]| all.iter().filter(|(q, _)| last(q) == last(p)).count() == 1;
    let (named, _) = all
        .iter()
        .find(|(p, _)| mentions(&p.join(".")))
        .or_else(|| {
            all.iter().find(|(_, v)| v.as_ref().is_some_and(|v| message.contains(&format!("\"{v}\""))))
        })
        .or_else(|| all.iter().find(|(p, _)| unique_last(p) && mentions(&last(p))))?;
    let mut key = vec!["actors", name, "params"];
    key.extend(named.iter().map(String::as_str));
    source.line_of_key(&key)
}

struct Prepared<A: Actor> {
    name: Arc<str>,
    critical: bool,
    /// SCHED_FIFO priority of a runtime thread of its own (`priority` in the graph).
    priority: Option<i32>,
    policy: RestartPolicy,
    config_dir: PathBuf,
    params: A::Params,
    table: PortTable,
    doorbell: Arc<Doorbell>,
    first: Option<(A, Declared<A::Input>)>,
}

impl<A: Actor> Supervised for Prepared<A> {
    fn spawn(self: Box<Self>, ctx: SupervisorContext) -> JoinHandle<()> {
        match self.priority.filter(|_| ctx.dedicated_threads) {
            Some(priority) => on_own_thread(*self, ctx, priority),
            None => tokio::spawn(supervise(*self, ctx)),
        }
    }
}

/// Supervises `prepared` on an OS thread of its own at SCHED_FIFO `priority`, in a
/// single-threaded runtime of its own: its incarnations, timers and I/O run there, so no busy
/// worker of the shared runtime delays them. Mailboxes and publishers work across runtimes
/// unchanged. A refused priority is logged and the actor keeps its thread at normal priority;
/// a thread or runtime the OS refuses leaves the actor on the shared runtime, said in the log.
/// The returned task ends when the supervision does.
fn on_own_thread<A: Actor>(prepared: Prepared<A>, ctx: SupervisorContext, priority: i32) -> JoinHandle<()> {
    let runtime = match tokio::runtime::Builder::new_current_thread().enable_all().build() {
        Ok(runtime) => runtime,
        Err(e) => {
            tracing::error!(actor = %prepared.name, "no runtime of its own ({e}): the actor shares the workers");
            return tokio::spawn(supervise(prepared, ctx));
        }
    };
    let (handover, taken) = std::sync::mpsc::channel::<(Prepared<A>, SupervisorContext)>();
    let (done, ended) = tokio::sync::oneshot::channel::<()>();
    let name = Arc::clone(&prepared.name);
    let thread = std::thread::Builder::new().name(format!("actor-{name}")).spawn(move || {
        let Ok((prepared, ctx)) = taken.recv() else { return };
        match set_realtime_priority(priority) {
            RealtimePriority::Fifo(p) => {
                tracing::info!(actor = %name, priority = p, "actor on a SCHED_FIFO thread")
            }
            RealtimePriority::Normal(why) => {
                tracing::warn!(actor = %name, %why, "actor on a thread of its own at normal priority")
            }
        }
        runtime.block_on(supervise(prepared, ctx));
        drop(done);
    });
    match thread {
        Ok(_) => {
            // The thread is waiting for exactly this; it cannot have gone.
            let _ = handover.send((prepared, ctx));
            tokio::spawn(async move {
                let _ = ended.await;
            })
        }
        Err(e) => {
            tracing::error!(actor = %prepared.name, "no thread of its own ({e}): the actor shares the workers");
            tokio::spawn(supervise(prepared, ctx))
        }
    }
}

impl<A: Actor> Prepared<A> {
    fn rebuild(&mut self, ctx: &SupervisorContext) -> Result<(A, Declared<A::Input>), ActorError> {
        let mut wiring = Wiring::rebuild(
            &self.name,
            &self.config_dir,
            Arc::clone(&ctx.clock),
            Arc::clone(&ctx.activity),
            Arc::clone(&self.doorbell),
            &mut self.table,
        );
        let actor = A::build(&self.params, &mut wiring);
        let declared = wiring.finish();
        let actor = actor?;
        let declared = declared.map_err(|errs| {
            ActorError::Failed(errs.iter().map(|e| e.message.clone()).collect::<Vec<_>>().join("; "))
        })?;
        Ok((actor, declared))
    }

    fn report(&self, ctx: &SupervisorContext, kind: SupervisorEventKind, reason: &str, restarts: u32) {
        let event = SupervisorEvent {
            time: ctx.clock.now(),
            actor: self.name.to_string(),
            kind,
            critical: self.critical,
            reason: reason.to_owned(),
            restarts_in_window: restarts,
        };
        match kind {
            SupervisorEventKind::Restarted => {
                tracing::info!(actor = %self.name, restarts, "actor restarted")
            }
            SupervisorEventKind::Stopped => tracing::info!(actor = %self.name, "actor stopped"),
            _ => tracing::error!(actor = %self.name, ?kind, reason, "actor failed"),
        }
        if self.critical {
            (ctx.escalate)(&event);
        }
        ctx.log.lock().unwrap_or_else(|e| e.into_inner()).push(event.clone());
        ctx.events.publish(event);
    }
}

/// How one incarnation of an actor ended.
#[derive(Clone, Debug, PartialEq)]
enum Exit {
    /// It stopped itself ([`Context::stop`]).
    Normal,
    /// It returned an error, panicked, or could not be built again. `mendable` is false for
    /// invalid parameters, which a restart would only meet again.
    Abnormal { reason: String, mendable: bool },
}

impl Exit {
    fn failed(e: &ActorError, what: &str) -> Exit {
        Exit::Abnormal { reason: format!("{what}{e}"), mendable: !matches!(e, ActorError::Params(_)) }
    }
}

/// Whether an actor that ended with `exit` is restarted under `policy` (before the restart
/// limit, which counts every restart in the window).
fn restarts(policy: Restart, exit: &Exit) -> bool {
    match (policy, exit) {
        (_, Exit::Abnormal { mendable: false, .. }) | (Restart::Never, _) => false,
        (Restart::Permanent, _) | (Restart::Transient, Exit::Abnormal { .. }) => true,
        (Restart::Transient, Exit::Normal) => false,
    }
}

async fn supervise<A: Actor>(mut prepared: Prepared<A>, ctx: SupervisorContext) {
    let mut failures: VecDeque<Time> = VecDeque::new();
    let panics = ctx.panics.windows_of(&prepared.name);
    let mut next = prepared.first.take().map(Ok);
    loop {
        let exit = match next.take() {
            Some(Ok((actor, declared))) => {
                let token = ctx.shutdown.child_token();
                let actor_ctx =
                    Context::new(Arc::clone(&prepared.name), Arc::clone(&ctx.clock), token.clone())
                        .with_run(ctx.shutdown.clone());
                for timer in declared.timers {
                    tokio::spawn(run_timer(Arc::clone(&ctx.clock), timer, token.clone()));
                }
                let starting = ctx.activity.begin();
                declared.inputs.iter().for_each(|port| port.unpark());
                let outcome = tokio::spawn(run_incarnation(
                    actor,
                    declared.inputs.clone(),
                    Arc::clone(&prepared.doorbell),
                    actor_ctx,
                    starting,
                    panics.clone(),
                ))
                .await;
                token.cancel();
                // Until a restart, messages for this actor must not hold the lockstep clock, or
                // the backoff could never elapse.
                declared.inputs.iter().for_each(|port| port.park());
                match outcome {
                    Ok(Ok(())) => Exit::Normal,
                    Ok(Err(e)) => Exit::failed(&e, ""),
                    Err(e) if e.is_panic() => Exit::Abnormal {
                        reason: format!("panicked: {}", panic_message(e.into_panic())),
                        mendable: true,
                    },
                    Err(_) => return,
                }
            }
            Some(Err(build_error)) => Exit::failed(&build_error, "restart failed: "),
            None => return,
        };
        if ctx.shutdown.is_cancelled() {
            return;
        }
        let reason = match &exit {
            Exit::Normal => "stopped".to_owned(),
            Exit::Abnormal { reason, .. } => reason.clone(),
        };
        if !restarts(prepared.policy.policy, &exit) {
            let kind =
                if exit == Exit::Normal { SupervisorEventKind::Stopped } else { SupervisorEventKind::GaveUp };
            prepared.report(&ctx, kind, &reason, u32::try_from(failures.len()).unwrap_or(u32::MAX));
            return;
        }
        let now = ctx.clock.now();
        failures.push_back(now);
        while failures.front().is_some_and(|&t| now.saturating_since(t) > prepared.policy.window()) {
            failures.pop_front();
        }
        let restarts = u32::try_from(failures.len()).unwrap_or(u32::MAX);
        if restarts > prepared.policy.max_restarts {
            prepared.report(&ctx, SupervisorEventKind::GaveUp, &reason, restarts);
            return;
        }
        let kind =
            if exit == Exit::Normal { SupervisorEventKind::Stopped } else { SupervisorEventKind::Failed };
        prepared.report(&ctx, kind, &reason, restarts);
        let wake = now + prepared.policy.backoff(restarts);
        tokio::select! {
            _ = ctx.shutdown.cancelled() => return,
            _ = ctx.clock.sleep_until(wake) => {}
        }
        let _restarting = ctx.activity.begin();
        let rebuilt = prepared.rebuild(&ctx);
        if rebuilt.is_ok() {
            prepared.report(&ctx, SupervisorEventKind::Restarted, &reason, restarts);
        }
        next = Some(rebuilt);
    }
}

/// One incarnation of an actor: start, handle inputs in arrival order, stop. When the run
/// ends, what had already arrived is still handled before `stop`, so that the last messages of
/// a run (the final status before `--exit-on-land` ends it) reach reports and logs. While one of
/// `panics` is active it panics instead of handling a message (the `actor_panic` fault).
async fn run_incarnation<A: Actor>(
    mut actor: A,
    inputs: Vec<Arc<dyn InputPort<A::Input>>>,
    doorbell: Arc<Doorbell>,
    ctx: Context,
    starting: Busy,
    panics: Vec<(Time, Option<Time>)>,
) -> Result<(), ActorError> {
    let result = async {
        actor.start(&ctx).await?;
        drop(starting);
        loop {
            let oldest =
                inputs.iter().filter_map(|p| p.oldest_arrival().map(|a| (a, p))).min_by_key(|(a, _)| *a);
            if let Some((input, busy)) = oldest.and_then(|(_, port)| port.take()) {
                if PanicSchedule::due(&panics, ctx.now()) {
                    drop(busy);
                    panic!("injected fault: actor_panic at {} (world file [[faults]])", ctx.now());
                }
                actor.handle(&ctx, input).await?;
                drop(busy);
                continue;
            }
            if ctx.shutdown().is_cancelled() {
                return Ok(());
            }
            tokio::select! {
                biased;
                _ = ctx.shutdown().cancelled() => {}
                _ = doorbell.rung() => {}
            }
        }
    }
    .await;
    actor.stop(&ctx).await;
    result
}

/// Delivers ticks at multiples of the timer's period on the graph clock.
async fn run_timer(clock: Arc<dyn Clock>, timer: TimerSpec, shutdown: CancellationToken) {
    let period_us = kestrel_proto::time::duration_micros(timer.period).max(1);
    loop {
        let next = Time::from_micros((clock.now().as_micros() / period_us + 1) * period_us);
        tokio::select! {
            _ = shutdown.cancelled() => return,
            _ = clock.sleep_until(next) => {}
        }
        timer.mailbox.deliver(next);
    }
}

fn panic_message(payload: Box<dyn std::any::Any + Send>) -> String {
    match payload.downcast::<String>() {
        Ok(s) => *s,
        Err(payload) => match payload.downcast::<&'static str>() {
            Ok(s) => (*s).to_owned(),
            Err(_) => "non-text panic payload".to_owned(),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn failed(mendable: bool) -> Exit {
        Exit::Abnormal { reason: "x".into(), mendable }
    }

    #[test]
    fn each_policy_restarts_as_erlang_and_kameo_say() {
        use Restart::*;
        let cases = [
            (Permanent, Exit::Normal, true),
            (Permanent, failed(true), true),
            (Transient, Exit::Normal, false),
            (Transient, failed(true), true),
            (Never, Exit::Normal, false),
            (Never, failed(true), false),
        ];
        for (policy, exit, expected) in cases {
            assert_eq!(restarts(policy, &exit), expected, "{policy:?} after {exit:?}");
        }
    }

    #[test]
    fn invalid_parameters_are_never_restarted() {
        let exit = Exit::failed(&ActorError::Params("gain < 0".into()), "");
        assert_eq!(exit, Exit::Abnormal { reason: "invalid parameters: gain < 0".into(), mendable: false });
        for policy in [Restart::Permanent, Restart::Transient, Restart::Never] {
            assert!(!restarts(policy, &exit), "{policy:?}");
        }
    }
}
