//! The world file's `actor_panic` faults: the one kind only the runtime can inject. At start-up
//! the runtime reads the world of every `sim` actor, checks that each `actor_panic` names an
//! actor of the graph, and hands each actor's windows to its supervisor; while a window is
//! active (`at_s ≤ t < at_s + for_s`, graph time), every incarnation of that actor panics on
//! the first message it would handle. So a `for_s` shorter than the restart backoff is one panic
//! and one restart; a window without `for_s` panics every restart until the supervisor gives up.
//! The simulator publishes the fault's start and end on `sim_fault` like any other.

use std::collections::BTreeMap;
use std::path::PathBuf;

use kestrel_proto::Time;
use kestrel_sim::{FaultKind, SimActorParams, World};

use crate::config::{ConfigError, LoadedConfig};

/// When each actor must panic: graph-time windows `[start, end)`, `None` = to the end.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PanicSchedule {
    windows: BTreeMap<String, Vec<(Time, Option<Time>)>>,
}

impl PanicSchedule {
    /// The windows of `actor` (none for most).
    pub fn windows_of(&self, actor: &str) -> Vec<(Time, Option<Time>)> {
        self.windows.get(actor).cloned().unwrap_or_default()
    }

    /// Whether `actor` must panic at `now`.
    pub fn due(windows: &[(Time, Option<Time>)], now: Time) -> bool {
        windows.iter().any(|&(start, end)| start <= now && end.is_none_or(|end| now < end))
    }

    /// The `actor_panic` faults of every `sim` actor's world in `config`, each checked to name
    /// an actor of the graph. A world that does not load is left for the sim actor to report.
    pub fn from_config(config: &LoadedConfig) -> Result<PanicSchedule, Vec<ConfigError>> {
        let names: Vec<&str> = config.graph.actors.keys().map(|k| k.get_ref().as_str()).collect();
        let mut schedule = PanicSchedule::default();
        let mut errors = Vec::new();
        for decl in config.graph.actors.values().filter(|d| d.kind.get_ref() == "sim") {
            let table = decl.params.as_ref().map(|p| p.get_ref().clone()).unwrap_or_default();
            let Ok(params) = toml::Value::Table(table).try_into::<SimActorParams>() else { continue };
            let path: PathBuf = config.source.dir().join(&params.world);
            let Ok(world) = World::load(&path) else { continue };
            let lines = std::fs::read_to_string(&path).map(|t| kestrel_sim::faults::entry_lines(&t));
            for (i, fault) in world.faults.iter().enumerate() {
                let FaultKind::ActorPanic { actor } = &fault.kind else { continue };
                if !names.contains(&actor.as_str()) {
                    errors.push(ConfigError {
                        file: path.clone(),
                        line: lines.as_ref().ok().and_then(|l| l.get(i).copied()),
                        message: format!(
                            "`faults[{i}].actor` \"{actor}\" is not an actor of the graph (actors: {})",
                            names.join(", ")
                        ),
                    });
                    continue;
                }
                schedule.windows.entry(actor.clone()).or_default().push((fault.start(), fault.end()));
            }
        }
        if errors.is_empty() { Ok(schedule) } else { Err(errors) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_actor_is_due_to_panic_only_inside_its_windows() {
        let s = Time::from_secs_f64;
        let windows = [(s(30.0), Some(s(30.01))), (s(50.0), None)];
        let due = |t| PanicSchedule::due(&windows, s(t));
        assert!(!due(29.999) && due(30.0) && due(30.005) && !due(30.01) && !due(49.9));
        assert!(due(50.0) && due(1e6), "without for_s: to the end");
        assert!(!PanicSchedule::due(&[], s(30.0)));
        assert_eq!(PanicSchedule::default().windows_of("estimator"), []);
    }
}
