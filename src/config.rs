//! The graph config: which actors run, their parameters, and how their ports are wired.
//!
//! ```toml
//! vehicle = "vehicles/quad_x.toml"   # what the simulator flies and the controller controls
//!
//! [run]
//! clock = "lockstep"          # or "realtime" (hardware)
//! speedup = 1.0               # lockstep pacing: simulated seconds per second; 0 = flat out
//!
//! [record]
//! topics = ["*"]              # what the logs hold: every topic, or a list of names
//! dir = "sim/logs"            # the vehicle's numbered logs (relative: to the state directory)
//!
//! [actors.sim]
//! type = "sim"                # which actor implementation (see `kestrel actors`)
//! critical = false            # a failure past the restart limit escalates to the commander
//! priority = 60               # realtime clock: a runtime thread of its own at SCHED_FIFO 60
//! restart = { policy = "transient", max_restarts = 5, window_s = 60.0, backoff_initial_s = 0.1, backoff_max_s = 5.0 }
//! params = { world = "worlds/empty.toml" }
//! inputs.actuators = { topic = "actuator_outputs", mailbox = "latest" }
//! outputs.imu = "imu"         # optional renames; an output publishes on its port's name
//! ```
//!
//! Every name a person can mistype keeps its place in the file, so a wrong name is reported as
//! `FILE:LINE: …` naming it, at start-up. Every duration and size is range-checked at load, with
//! the limits below (`MAX_*`): a value that would overflow a `Duration` or an allocation is a
//! located error, never a panic or an abort later.

use std::collections::BTreeMap;
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use serde::Deserialize;
use toml::Spanned;

use crate::compose::{Layer, compose};
use crate::mailbox::MailboxKind;

/// Longest run a config or `--duration` may ask for (s): about 31 years, far past any flight,
/// and far inside what the clock's microseconds hold.
pub const MAX_DURATION_S: f64 = 1e9;
/// `[run] speedup` range besides 0 (as fast as possible): slower than a thousandth of real time
/// or faster than a million times it is a typo, not a pace.
pub const SPEEDUP_RANGE: (f64, f64) = (1e-3, 1e6);
/// `[run] status_period_s` range besides 0 (no status line) (s).
pub const STATUS_PERIOD_RANGE_S: (f64, f64) = (0.1, 86_400.0);
/// SCHED_FIFO priorities an actor may ask for: above every normal process, below the
/// controller's loop thread (80 by default) and the HIL world (90).
pub const PRIORITY_RANGE: (i32, i32) = (1, 79);

/// Longest restart window or backoff (s): a day.
pub const MAX_RESTART_S: f64 = 86_400.0;

/// A config problem, located in its file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub struct ConfigError {
    pub file: PathBuf,
    /// 1-based line, when the problem has a place.
    pub line: Option<usize>,
    pub message: String,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(f, "{}:{}: {}", self.file.display(), line, self.message),
            None => write!(f, "{}: {}", self.file.display(), self.message),
        }
    }
}

/// The config file's text and path, to turn spans into line numbers.
///
/// A composed config (`extends`, see [`crate::compose`]) is parsed from its merged text; its
/// errors are placed back in the file that spelled the key (see [`Source::error_on_line`]).
#[derive(Clone, Debug)]
pub struct Source {
    /// The file that was run.
    pub path: PathBuf,
    text: Arc<str>,
    /// The composition's files, the file that was run first; empty when it extends nothing.
    layers: Arc<[Layer]>,
}

impl Source {
    /// The source of a file that extends nothing.
    pub fn plain(path: &Path, text: &str) -> Source {
        Source { path: path.to_owned(), text: Arc::from(text), layers: Arc::from([]) }
    }

    /// An error on `line` of the text (merged text when composed), placed in the file and on
    /// the line that spelled the key there.
    pub fn error_on_line(&self, line: Option<usize>, message: impl Into<String>) -> ConfigError {
        let message = message.into();
        let Some(merged_line) = line.filter(|_| !self.layers.is_empty()) else {
            return ConfigError { file: self.path.clone(), line, message };
        };
        let place = key_path_at_line(&self.text, merged_line).and_then(|path| {
            let keys: Vec<&str> = path.iter().map(String::as_str).collect();
            self.layers.iter().find_map(|layer| {
                let line = line_of_key_in(&layer.text, &keys)?;
                Some(ConfigError { file: layer.path.clone(), line: Some(line), message: message.clone() })
            })
        });
        place.unwrap_or(ConfigError { file: self.path.clone(), line: None, message })
    }

    /// The 1-based line holding byte `offset`.
    pub fn line_of(&self, offset: usize) -> usize {
        line_in(&self.text, offset)
    }

    /// An error at `span`.
    pub fn error_at(&self, span: Range<usize>, message: impl Into<String>) -> ConfigError {
        self.error_on_line(Some(self.line_of(span.start)), message)
    }

    /// An error without a place.
    pub fn error(&self, message: impl Into<String>) -> ConfigError {
        ConfigError { file: self.path.clone(), line: None, message: message.into() }
    }

    /// The 1-based line of the key at `path` (table names, then the key; an index for an array
    /// element), if the text has it: `["run", "status_period_s"]`,
    /// `["actors", "link", "params", "endpoints", "1", "bind"]`.
    pub fn line_of_key(&self, path: &[&str]) -> Option<usize> {
        line_of_key_in(&self.text, path)
    }

    /// An error at the key `path` (see [`Source::line_of_key`]), or without a place.
    pub fn error_at_key(&self, path: &[&str], message: impl Into<String>) -> ConfigError {
        self.error_on_line(self.line_of_key(path), message)
    }

    /// The directory relative paths in the config resolve against.
    pub fn dir(&self) -> &Path {
        self.path.parent().unwrap_or(Path::new("."))
    }
}

/// 1-based line of `offset` in `text`.
fn line_in(text: &str, offset: usize) -> usize {
    let end = offset.min(text.len());
    text.as_bytes()[..end].iter().filter(|&&b| b == b'\n').count() + 1
}

/// The 1-based line of the key at `path` in `text` (see [`Source::line_of_key`]).
fn line_of_key_in(text: &str, path: &[&str]) -> Option<usize> {
    let document = toml::de::DeTable::parse(text).ok()?;
    let (mut table, mut span) = (document.get_ref(), None);
    let mut keys = path.iter().peekable();
    while let Some(key) = keys.next() {
        let (name, mut value) = table.get_key_value(*key)?;
        span = Some(name.span());
        // Array elements: the element's own span (an inline table's brace).
        while let (toml::de::DeValue::Array(items), Some(index)) =
            (value.get_ref(), keys.peek().and_then(|k| k.parse::<usize>().ok()))
        {
            keys.next();
            value = items.get(index)?;
            span = Some(value.span());
        }
        if keys.peek().is_some() {
            let toml::de::DeValue::Table(inner) = value.get_ref() else { return None };
            table = inner;
        }
    }
    span.map(|s| line_in(text, s.start))
}

/// The longest key path (array elements as indices) whose key sits on 1-based `line` of `text`.
fn key_path_at_line(text: &str, line: usize) -> Option<Vec<String>> {
    fn walk(
        text: &str,
        value: &toml::de::DeValue<'_>,
        prefix: &mut Vec<String>,
        line: usize,
        best: &mut Option<Vec<String>>,
    ) {
        match value {
            toml::de::DeValue::Table(table) => {
                for (key, child) in table.iter() {
                    prefix.push(key.get_ref().to_string());
                    if line_in(text, key.span().start) == line
                        && best.as_ref().is_none_or(|b| b.len() < prefix.len())
                    {
                        *best = Some(prefix.clone());
                    }
                    walk(text, child.get_ref(), prefix, line, best);
                    prefix.pop();
                }
            }
            toml::de::DeValue::Array(items) => {
                for (i, item) in items.iter().enumerate() {
                    prefix.push(i.to_string());
                    walk(text, item.get_ref(), prefix, line, best);
                    prefix.pop();
                }
            }
            _ => {}
        }
    }
    let document = toml::de::DeTable::parse(text).ok()?;
    let mut best = None;
    let root = toml::de::DeValue::Table(document.get_ref().clone());
    walk(text, &root, &mut Vec::new(), line, &mut best);
    best
}

/// Which clock the graph runs on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ClockKind {
    /// Simulation time, advanced when the graph is idle (deterministic).
    #[default]
    Lockstep,
    /// The OS monotonic clock (hardware).
    Realtime,
}

/// `[run]`: how the graph runs.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RunConfig {
    pub clock: ClockKind,
    /// Lockstep pacing in simulated seconds per wall second; 0 runs as fast as possible,
    /// otherwise within [`SPEEDUP_RANGE`].
    pub speedup: f64,
    /// Stop after this much graph time (s), at most [`MAX_DURATION_S`]; none runs until Ctrl-C.
    pub duration_s: Option<f64>,
    /// Wall-clock period of the status line (s), within [`STATUS_PERIOD_RANGE_S`]; exactly 0
    /// turns it off (a negative or NaN period is an error, not a way to spell "off").
    pub status_period_s: f64,
}

impl Default for RunConfig {
    fn default() -> Self {
        RunConfig { clock: ClockKind::Lockstep, speedup: 1.0, duration_s: None, status_period_s: 1.0 }
    }
}

/// `[state]`: what the vehicle keeps across restarts.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StateConfig {
    /// Where the link keeps the uploaded mission, fence and rally points and the parameters set
    /// (its `state_dir`), relative to the state directory ([`state_dir`]); `--instance N` (N > 0)
    /// adds `instance-N`. Runs scripted with `--mission` or `--auto` keep nothing: they start
    /// from their flags alone. `None`: nothing outlives a run.
    pub dir: Option<PathBuf>,
}

/// `[record]`: what the flight log holds.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RecordConfig {
    /// Record to this file (relative to the working directory); `--record` overrides it.
    pub path: Option<PathBuf>,
    /// Topic names to record; `"*"` records every topic.
    pub topics: Vec<Spanned<String>>,
    /// The vehicle's log directory: each arming-to-disarming writes its own numbered log there
    /// (`recorder::onboard`), which ground stations download over MAVLink. Relative to the
    /// state directory ([`state_dir`]); `--instance N` (N > 0) adds `instance-N`. Unused while
    /// `path` or `--record` names one file. `None`: no logs on the vehicle.
    pub dir: Option<PathBuf>,
    /// One log for the whole run, armed or not (ArduPilot's LOG_DISARMED=1).
    pub log_disarmed: bool,
    /// Most megabytes (10^6 bytes) the logs may hold when a new one starts, 1..=10^6; the oldest
    /// are removed first.
    pub budget_mb: u64,
    /// Most logs kept, 2..=65535 (ArduPilot's LOG_MAX_FILES, default 500).
    pub max_files: usize,
}

impl Default for RecordConfig {
    fn default() -> Self {
        RecordConfig {
            path: None,
            topics: vec![Spanned::new(0..0, "*".to_owned())],
            dir: None,
            log_disarmed: false,
            budget_mb: 1000,
            max_files: 500,
        }
    }
}

impl RecordConfig {
    /// The onboard log's settings with `dir` resolved, or why they are out of range.
    pub fn onboard(&self) -> Result<Option<crate::recorder::OnboardLog>, String> {
        let Some(dir) = &self.dir else { return Ok(None) };
        if !(1..=1_000_000).contains(&self.budget_mb) {
            return Err(format!("[record] budget_mb = {} is outside 1..=1000000", self.budget_mb));
        }
        if !(2..=65535).contains(&self.max_files) {
            return Err(format!("[record] max_files = {} is outside 2..=65535", self.max_files));
        }
        let dir = state_dir().join(dir);
        Ok(Some(crate::recorder::OnboardLog {
            dir,
            log_disarmed: self.log_disarmed,
            budget_bytes: self.budget_mb * 1_000_000,
            max_files: self.max_files,
        }))
    }
}

/// Where a run keeps what outlives it (logs): `$KESTREL_STATE_DIR`, else systemd's
/// `$STATE_DIRECTORY` (`/var/lib/kestrel` under packaging/kestrel.service), else
/// `$XDG_STATE_HOME/kestrel`, else `$HOME/.local/state/kestrel` (the XDG default), else the temp
/// dir's `kestrel-state`.
pub fn state_dir() -> PathBuf {
    let var = |name| std::env::var_os(name).filter(|v| !v.is_empty()).map(PathBuf::from);
    var("KESTREL_STATE_DIR")
        .or_else(|| var("STATE_DIRECTORY"))
        .or_else(|| var("XDG_STATE_HOME").map(|d| d.join("kestrel")))
        .or_else(|| var("HOME").map(|d| d.join(".local/state/kestrel")))
        .unwrap_or_else(|| std::env::temp_dir().join("kestrel-state"))
}

/// When the supervisor restarts an actor, in Erlang's and kameo's words.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Restart {
    /// Always restarted, after a normal end ([`kestrel_proto::Context::stop`]) too.
    Permanent,
    /// Restarted only after an abnormal end (an error or a panic); a normal end is final. The
    /// default: an actor that ends normally has finished its work, and running it again would
    /// repeat it, while one that failed should come back.
    #[default]
    Transient,
    /// Never restarted (Erlang's `temporary`): the first failure is final.
    Never,
}

/// `restart = {…}`: the supervisor's one-for-one restart policy for an actor.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RestartPolicy {
    /// When to restart: `"permanent"`, `"transient"` (default) or `"never"`. Whatever it says,
    /// an actor whose parameters are invalid (`ActorError::Params`) is not restarted.
    pub policy: Restart,
    /// Restarts allowed within `window_s`; one more and the actor stays stopped.
    pub max_restarts: u32,
    /// The window over which restarts are counted (s).
    pub window_s: f64,
    /// Delay before the first restart (s); doubles with each failure in the window.
    pub backoff_initial_s: f64,
    /// Cap on the restart delay (s).
    pub backoff_max_s: f64,
}

impl Default for RestartPolicy {
    fn default() -> Self {
        RestartPolicy {
            policy: Restart::default(),
            max_restarts: 5,
            window_s: 60.0,
            backoff_initial_s: 0.1,
            backoff_max_s: 5.0,
        }
    }
}

impl RestartPolicy {
    /// The restart window.
    pub fn window(&self) -> Duration {
        seconds(self.window_s)
    }

    /// The delay before restart number `n` (1-based) within the window.
    pub fn backoff(&self, n: u32) -> Duration {
        let factor = 2f64.powi(n.saturating_sub(1).min(60) as i32);
        seconds((self.backoff_initial_s * factor).min(self.backoff_max_s))
    }

    /// The first field outside `0..=MAX_RESTART_S` seconds, named, with what is wrong with it.
    fn validate(&self) -> Result<(), (&'static str, String)> {
        for (field, v) in [
            ("window_s", self.window_s),
            ("backoff_initial_s", self.backoff_initial_s),
            ("backoff_max_s", self.backoff_max_s),
        ] {
            if !(v.is_finite() && (0.0..=MAX_RESTART_S).contains(&v)) {
                return Err((
                    field,
                    format!("restart {field} = {v:?}: expected 0..={MAX_RESTART_S} seconds"),
                ));
            }
        }
        Ok(())
    }
}

/// One input route: the topic a port subscribes to and its mailbox kind.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Route {
    pub topic: Spanned<String>,
    /// `"latest"` or `"queue(N)"`.
    pub mailbox: Spanned<String>,
}

/// `[actors.NAME]`: one running actor.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActorDecl {
    /// The actor implementation.
    #[serde(rename = "type")]
    pub kind: Spanned<String>,
    /// Whether a failure of this actor is a flight-safety event (estimator, controller).
    #[serde(default)]
    pub critical: bool,
    #[serde(default)]
    pub restart: RestartPolicy,
    /// On the realtime clock, the actor runs on a runtime thread of its own at this SCHED_FIFO
    /// priority ([`PRIORITY_RANGE`]), so that a busy machine cannot starve it: PX4 runs its
    /// estimator and sensor drivers on high-priority work queues for the same reason. Without
    /// it (and always in lockstep, which is one deterministic thread) the actor shares the
    /// runtime's workers.
    #[serde(default)]
    pub priority: Option<i32>,
    /// The actor's own parameters.
    #[serde(default)]
    pub params: Option<Spanned<toml::Table>>,
    /// Input port → route.
    #[serde(default)]
    pub inputs: BTreeMap<Spanned<String>, Route>,
    /// Output port → topic, where it differs from the port's name.
    #[serde(default)]
    pub outputs: BTreeMap<Spanned<String>, Spanned<String>>,
}

/// A whole graph config.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GraphConfig {
    /// The vehicle file (relative to the graph's directory) that the simulator flies and the
    /// controller controls: mass, inertia, frame, motors and sensors written once
    /// ([`crate::vehicle`]). None: each actor's own parameters, which must agree.
    #[serde(default)]
    pub vehicle: Option<Spanned<String>>,
    #[serde(default)]
    pub run: RunConfig,
    #[serde(default)]
    pub record: RecordConfig,
    #[serde(default)]
    pub state: StateConfig,
    pub actors: BTreeMap<Spanned<String>, ActorDecl>,
}

/// A parsed config with its source, for located errors.
#[derive(Clone, Debug)]
pub struct LoadedConfig {
    pub graph: GraphConfig,
    pub source: Source,
    /// The merged document the graph was read from (`kestrel run --print-config`).
    pub merged: toml::Table,
}

impl LoadedConfig {
    /// Reads and parses a config file.
    pub fn load(path: &Path) -> Result<LoadedConfig, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|e| ConfigError {
            file: path.to_owned(),
            line: None,
            message: format!("cannot read the config: {e}"),
        })?;
        LoadedConfig::parse(path, &text)
    }

    /// Parses config text that came from `path`, merging the bases it `extends` (read from
    /// the disk, relative to `path`'s directory).
    pub fn parse(path: &Path, text: &str) -> Result<LoadedConfig, ConfigError> {
        let composed = compose(path, text)?;
        let source = if composed.layers.is_empty() {
            Source::plain(path, text)
        } else {
            let merged = toml::to_string(&composed.table).map_err(|e| ConfigError {
                file: path.to_owned(),
                line: None,
                message: format!("cannot write the merged config: {e}"),
            })?;
            Source {
                path: path.to_owned(),
                text: Arc::from(merged.as_str()),
                layers: Arc::from(composed.layers),
            }
        };
        let graph: GraphConfig = toml::from_str(&source.text).map_err(|e| {
            source.error_on_line(e.span().map(|s| source.line_of(s.start)), e.message().trim())
        })?;
        let config = LoadedConfig { graph, source, merged: composed.table };
        config.validate()?;
        Ok(config)
    }

    /// The merged graph as TOML.
    pub fn merged_toml(&self) -> Result<String, toml::ser::Error> {
        toml::to_string(&self.merged)
    }

    /// Checks every range the runtime relies on (also after a caller changed the graph).
    pub fn validate(&self) -> Result<(), ConfigError> {
        let run = &self.graph.run;
        let at_run = |key: &str, message: String| self.source.error_at_key(&["run", key], message);
        if let Err(m) = check_speedup(run.speedup) {
            return Err(at_run("speedup", format!("[run] {m}")));
        }
        if let Some(Err(m)) = run.duration_s.map(check_duration_s) {
            return Err(at_run("duration_s", format!("[run] duration_s = {m}")));
        }
        let (lo, hi) = STATUS_PERIOD_RANGE_S;
        let period = run.status_period_s;
        if !(period == 0.0 || (lo..=hi).contains(&period)) {
            return Err(at_run(
                "status_period_s",
                format!(
                    "[run] status_period_s = {period:?}: expected {lo}..={hi} seconds, or 0 for no status line"
                ),
            ));
        }
        for (name, decl) in &self.graph.actors {
            decl.restart.validate().map_err(|(field, m)| {
                let at = self.source.line_of_key(&["actors", name.get_ref(), "restart", field]);
                let line = at.unwrap_or_else(|| self.source.line_of(name.span().start));
                self.source.error_on_line(Some(line), format!("actor '{}': {m}", name.get_ref()))
            })?;
            let (lo, hi) = PRIORITY_RANGE;
            if let Some(p) = decl.priority.filter(|p| !(lo..=hi).contains(p)) {
                let at = self.source.line_of_key(&["actors", name.get_ref(), "priority"]);
                let line = at.unwrap_or_else(|| self.source.line_of(name.span().start));
                return Err(self.source.error_on_line(
                    Some(line),
                    format!("actor '{}': priority = {p}: expected {lo}..={hi} (SCHED_FIFO)", name.get_ref()),
                ));
            }
            for (port, route) in &decl.inputs {
                route.mailbox.get_ref().parse::<MailboxKind>().map_err(|m| {
                    self.source.error_at(
                        route.mailbox.span(),
                        format!("actor '{}', input '{}': {m}", name.get_ref(), port.get_ref()),
                    )
                })?;
            }
        }
        Ok(())
    }
}

/// `s` seconds, for a value the config checks bounded; an out-of-range one saturates rather
/// than panics.
fn seconds(s: f64) -> Duration {
    Duration::try_from_secs_f64(s).unwrap_or(if s > 0.0 { Duration::MAX } else { Duration::ZERO })
}

/// Checks a lockstep pace: 0 (flat out) or within [`SPEEDUP_RANGE`].
pub fn check_speedup(speedup: f64) -> Result<(), String> {
    let (lo, hi) = SPEEDUP_RANGE;
    if speedup == 0.0 || (lo..=hi).contains(&speedup) {
        Ok(())
    } else {
        Err(format!("speedup = {speedup:?}: expected {lo}..={hi}, or 0 for as fast as possible"))
    }
}

/// A run length in seconds, `(0, MAX_DURATION_S]`; the error starts with the value.
pub fn check_duration_s(s: f64) -> Result<Duration, String> {
    if s > 0.0 && s <= MAX_DURATION_S {
        Ok(Duration::from_secs_f64(s))
    } else {
        Err(format!("{s:?}: expected a number of seconds in (0, {MAX_DURATION_S}]"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<LoadedConfig, ConfigError> {
        LoadedConfig::parse(Path::new("test.toml"), text)
    }

    #[test]
    fn syntax_errors_name_file_and_line() {
        let err = parse("[actors.a]\ntype = \"sim\"\ninputs.x = { topic = \"t\", mailbox = \"fifo\" }\n")
            .unwrap_err();
        assert_eq!(err.line, Some(3), "{err}");
        assert!(err.to_string().starts_with("test.toml:3: "), "{err}");
        assert!(err.message.contains("fifo"), "{err}");

        let err = parse("[actors.a]\ntype = \"sim\"\nbogus = 1\n").unwrap_err();
        assert_eq!(err.line, Some(3), "{err}");
        assert!(err.message.contains("bogus"), "{err}");
    }

    #[test]
    fn durations_out_of_range_are_located_errors_not_panics() {
        for (value, line) in [("inf", 3), ("1e30", 3), ("-1.0", 3), ("nan", 3)] {
            let text = format!("[run]\nclock = \"lockstep\"\nstatus_period_s = {value}\n[actors]\n");
            let err = parse(&text).unwrap_err();
            assert_eq!(err.line, Some(line), "{value}: {err}");
            assert!(err.message.contains("status_period_s"), "{err}");
        }
        assert!(parse("[run]\nstatus_period_s = 0.0\n[actors]\n").is_ok(), "0 means no status line");
        for text in ["[run]\nduration_s = 1e30\n[actors]\n", "[run]\nspeedup = 1e-300\n[actors]\n"] {
            let err = parse(text).unwrap_err();
            assert_eq!(err.line, Some(2), "{err}");
        }
        let err = parse("[actors.a]\ntype = \"sim\"\nrestart = { window_s = 1e30 }\n").unwrap_err();
        assert_eq!(err.line, Some(3), "{err}");
        assert!(err.message.contains("window_s"), "{err}");
    }

    #[test]
    fn a_priority_outside_the_actors_range_is_a_located_error() {
        for p in [0, -1, 80, 99] {
            let err = parse(&format!("[actors.a]\ntype = \"sim\"\npriority = {p}\n")).unwrap_err();
            assert_eq!(err.line, Some(3), "{p}: {err}");
            assert!(err.message.contains(&format!("priority = {p}: expected 1..=79")), "{err}");
        }
        assert!(parse("[actors.a]\ntype = \"sim\"\npriority = 79\n").is_ok());
    }

    #[test]
    fn a_queue_deeper_than_the_cap_is_a_located_error() {
        let text =
            "[actors.a]\ntype = \"sim\"\ninputs.x = { topic = \"t\", mailbox = \"queue(1000000000000)\" }\n";
        let err = parse(text).unwrap_err();
        assert_eq!(err.line, Some(3), "{err}");
        assert!(err.message.contains("at most 1048576"), "{err}");
        let text = "[actors.a]\ntype = \"sim\"\ninputs.x = { topic = \"t\", mailbox = \"queue(1048576)\" }\n";
        assert!(parse(text).is_ok());
    }

    #[test]
    fn keys_are_found_by_their_path() {
        let config = parse("[run]\nspeedup = 1.0\n\n[actors.a]\ntype = \"sim\"\nparams.seed = 3\n").unwrap();
        assert_eq!(config.source.line_of_key(&["run", "speedup"]), Some(2));
        assert_eq!(config.source.line_of_key(&["actors", "a", "params", "seed"]), Some(6));
        assert_eq!(config.source.line_of_key(&["actors", "b"]), None);
    }

    #[test]
    fn restart_backoff_doubles_up_to_its_cap() {
        let p = RestartPolicy { backoff_initial_s: 0.1, backoff_max_s: 0.5, ..RestartPolicy::default() };
        let ms: Vec<u128> = (1..=5).map(|n| p.backoff(n).as_millis()).collect();
        assert_eq!(ms, [100, 200, 400, 500, 500]);
    }
}
