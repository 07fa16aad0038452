//! The parameter protocol (PARAM_REQUEST_LIST / PARAM_REQUEST_READ / PARAM_SET / PARAM_VALUE),
//! values C-cast into `param_value` (MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST).
//!
//! The table is what the graph's actors declare (`ParamDecl` on topic `param_decl`: each owner
//! its own live parameters, with values, ranges and units), plus any the link's config lists
//! for benches without owners; an owner's declaration replaces a config entry of the same
//! name. Entries are kept sorted by name, so the MAVLink index of a parameter does not depend
//! on which actor started first.
//!
//! A set outside the parameter's range is refused: the current value is echoed and a STATUSTEXT
//! says why. So is a set, while armed (the commander's `VehicleStatus`), of a parameter its owner
//! declared disarmed-only (`param_def::WhileArmed::Locked`: pulse ranges, sensor calibration,
//! board trim): "SERVO1_MAX: cannot change while armed", and the value still in force, which the
//! ground station then shows. An unknown name gets a STATUSTEXT only (there is no value to
//! echo). An accepted set of a parameter the link serves itself is echoed at once. One an actor
//! owns is published as `ParamSet` for the owner, which validates it again and declares the value
//! it really uses; only that declaration is echoed, as PX4 answers with the value in use: the set
//! value when the owner took it, the owner's own when it refused (with a STATUSTEXT). An owner that does not answer
//! within [`CONFIRM_TIMEOUT`] — its `param_set` input unrouted, the actor down — leaves the old
//! value, which is echoed with a STATUSTEXT saying so: a ground station never sees a value the
//! vehicle does not use.
//!
//! Values set over MAVLink, or restored from the parameter file, are the ones persisted. Stored
//! values whose owner has not declared yet are held and sent to it (`ParamSet`) when it does,
//! and again whenever it restarts with other values.

use std::collections::BTreeMap;
use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::messages::{ParamDecl, ParamSet};
use mavlink::dialects::ardupilotmega::{MavMessage, MavParamType, MavSeverity, PARAM_VALUE_DATA};

use super::events::statustext;
use super::{Outputs, Sender, Service, ToGraph};
use crate::config::{ParamKind, ParamSpec};

mod file;
mod saving;
pub use file::{parse_param_file, render_param_file};
pub use saving::{ParamWrite, short_reason};

/// Why a parameter table could not be built.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ParamError {
    #[error("parameter '{0}': a name must be 1 to 16 ASCII characters")]
    Name(String),
    #[error("{0} parameters: MAVLink indexes at most 32767")]
    TooMany(usize),
    #[error("parameter '{0}' is listed twice")]
    Duplicate(String),
    #[error("parameter '{name}': value {value} is outside {min}..={max} or not finite")]
    OutOfRange { name: String, value: f64, min: f64, max: f64 },
}

/// How long an owner has to declare the value it took after a `ParamSet` (in-process, it
/// answers within one message hop; a second is generous and still short for a ground station,
/// which repeats an unanswered PARAM_SET after about that long).
pub const CONFIRM_TIMEOUT: Duration = Duration::from_secs(1);

/// A set sent to an owner, waiting for its declaration.
#[derive(Debug)]
struct Awaiting {
    name: String,
    wanted: f64,
    deadline: Time,
    /// A stored value sent at the owner's start, not a ground station's set: no echo.
    restored: bool,
}

/// One parameter and who answers for it.
#[derive(Debug)]
struct Entry {
    spec: ParamSpec,
    /// The actor that declared it; `None` for one listed in the link's config.
    owner: Option<String>,
    /// Set over MAVLink or restored from the file: written to the file.
    persist: bool,
    /// Declared disarmed-only by its owner: a PARAM_SET while armed is refused.
    disarmed_only: bool,
}

/// The vehicle's parameters, sorted by name (that order is the MAVLink index).
#[derive(Debug)]
pub struct ParamTable {
    entries: Vec<Entry>,
    /// Stored values (from the file) no entry has claimed yet, by name.
    pending: BTreeMap<String, f64>,
    /// Sets sent to owners and not yet confirmed.
    awaiting: Vec<Awaiting>,
    /// Next index of a PARAM_REQUEST_LIST being streamed.
    list_cursor: Option<usize>,
    /// A value changed that the parameter file must follow (`take_changed`): a PARAM_SET that
    /// went to its owner, or a declaration whose owner refused a persisted value.
    changed: bool,
    /// Whether the vehicle is armed, from the commander's latest `VehicleStatus`; false until
    /// one arrives (the link starts with the vehicle on the ground, and an owner that knows the
    /// armed state refuses a locked set on its own as well).
    armed: bool,
    /// Echoes wait for the parameter file (`saving.rs`): set when the link has one.
    hold_echoes: bool,
    /// Changes taken and not yet known to be on disk, oldest first.
    unsaved: Vec<saving::Unsaved>,
    /// The number of the last parameter file text handed out (`take_write`).
    next_batch: u64,
}

/// PARAM_VALUEs sent per scheduler tick while a parameter list is streaming: a burst of hundreds
/// of datagrams overflows a ground station's socket buffer, 25 per 20 ms (1250/s) does not.
pub const PARAMS_PER_TICK: usize = 25;

/// What a declaration changed.
#[derive(Debug, Default)]
pub struct Declared {
    /// PARAM_VALUEs and STATUSTEXTs to send, and `ParamSet`s for the owner.
    pub out: Outputs,
    /// A persisted value changed (the owner refused it): the file needs rewriting.
    pub persist_changed: bool,
}

impl ParamTable {
    /// Checks `specs` (names, ranges, defaults): the parameters the link serves itself.
    pub fn new(specs: Vec<ParamSpec>) -> Result<ParamTable, ParamError> {
        if specs.len() > i16::MAX as usize {
            return Err(ParamError::TooMany(specs.len()));
        }
        for (i, s) in specs.iter().enumerate() {
            if s.name.is_empty() || s.name.len() > 16 || !s.name.is_ascii() {
                return Err(ParamError::Name(s.name.clone()));
            }
            if specs[..i].iter().any(|o| o.name == s.name) {
                return Err(ParamError::Duplicate(s.name.clone()));
            }
            if !in_range(s, s.value) {
                return Err(ParamError::OutOfRange {
                    name: s.name.clone(),
                    value: s.value,
                    min: s.min,
                    max: s.max,
                });
            }
        }
        let mut entries: Vec<Entry> = specs
            .into_iter()
            .map(|spec| Entry { spec, owner: None, persist: false, disarmed_only: false })
            .collect();
        entries.sort_by(|a, b| a.spec.name.cmp(&b.spec.name));
        Ok(ParamTable {
            entries,
            pending: BTreeMap::new(),
            awaiting: Vec::new(),
            list_cursor: None,
            changed: false,
            armed: false,
            hold_echoes: false,
            unsaved: Vec::new(),
            next_batch: 0,
        })
    }

    /// The number of parameters.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// The vehicle's armed state, from the commander's `VehicleStatus`.
    pub fn set_armed(&mut self, armed: bool) {
        self.armed = armed;
    }

    /// Whether an actor of the graph has declared `name` (not only the config listing it).
    pub fn is_declared(&self, name: &str) -> bool {
        self.entries.iter().any(|e| e.spec.name == name && e.owner.is_some())
    }

    /// `(name, value)` of every parameter, in index order.
    pub fn values(&self) -> impl Iterator<Item = (&str, f64)> {
        self.entries.iter().map(|e| (e.spec.name.as_str(), e.spec.value))
    }

    /// `(name, value)` of what the parameter file keeps: values set over MAVLink or restored,
    /// and stored values no owner has declared yet (an actor that does not run in this graph).
    pub fn persisted(&self) -> BTreeMap<&str, f64> {
        let set = self.entries.iter().filter(|e| e.persist).map(|e| (e.spec.name.as_str(), e.spec.value));
        self.pending.iter().map(|(n, v)| (n.as_str(), *v)).chain(set).collect()
    }

    /// Applies a stored value at start-up: at once to a config-listed parameter (refused, with
    /// the reason, when out of range), else held for the owner that will declare it.
    pub fn restore(&mut self, name: &str, value: f64) -> Result<(), ParamError> {
        let Some(entry) = self.entries.iter_mut().find(|e| e.spec.name == name) else {
            if !value.is_finite() {
                return Err(ParamError::OutOfRange {
                    name: name.to_owned(),
                    value,
                    min: f64::NEG_INFINITY,
                    max: f64::INFINITY,
                });
            }
            self.pending.insert(name.to_owned(), value);
            return Ok(());
        };
        let spec = &mut entry.spec;
        if !in_range(spec, value) {
            return Err(ParamError::OutOfRange {
                name: name.to_owned(),
                value,
                min: spec.min,
                max: spec.max,
            });
        }
        spec.value = quantise(spec.kind, value);
        entry.persist = true;
        Ok(())
    }

    /// Takes an actor's declaration of its parameters (see the module docs).
    pub fn declare(&mut self, decl: &ParamDecl, now: Time) -> Declared {
        let mut done = Declared::default();
        if let Err(e) = decl.check() {
            let text = format!("Params of {}: {e}", decl.owner);
            done.out.mav.push(statustext(MavSeverity::MAV_SEVERITY_ERROR, &text));
            return done;
        }
        let answered = self
            .awaiting
            .iter()
            .find(|a| {
                self.entries.iter().any(|e| e.spec.name == a.name && e.owner.as_deref() == Some(&decl.owner))
            })
            .map(|a| a.name.clone());
        for p in &decl.params {
            let index = self.entries.iter().position(|e| e.spec.name == p.name);
            let owned_by_other =
                index.and_then(|i| self.entries[i].owner.as_deref()).is_some_and(|o| o != decl.owner);
            if owned_by_other {
                let text = format!("Param {}: declared by {} too; ignored", p.name, decl.owner);
                done.out.mav.push(statustext(MavSeverity::MAV_SEVERITY_ERROR, &text));
                continue;
            }
            let spec = ParamSpec {
                name: p.name.clone(),
                value: p.value,
                min: p.min,
                max: p.max,
                kind: if p.integer { ParamKind::Int32 } else { ParamKind::Real32 },
                unit: p.unit.clone(),
            };
            match index {
                Some(i) if self.entries[i].owner.is_some() => {
                    self.entries[i].disarmed_only = p.disarmed_only;
                    self.redeclared(i, spec, (decl.start, answered.as_deref()), now, &mut done);
                }
                _ => {
                    // New, or replacing a config entry: a stored or config-set value wins.
                    let wanted = index
                        .filter(|&i| self.entries[i].persist)
                        .map(|i| self.entries[i].spec.value)
                        .or_else(|| self.pending.remove(&p.name));
                    let entry = Entry {
                        spec,
                        owner: Some(decl.owner.clone()),
                        persist: false,
                        disarmed_only: p.disarmed_only,
                    };
                    let i = match index {
                        Some(i) => {
                            self.entries[i] = entry;
                            i
                        }
                        None => {
                            let at = self.entries.partition_point(|e| e.spec.name < p.name);
                            self.entries.insert(at, entry);
                            at
                        }
                    };
                    if let Some(value) = wanted {
                        self.want(i, value, now, &mut done);
                    }
                }
            }
        }
        self.changed |= done.persist_changed;
        done
    }

    /// An owner declared parameter `i` again: after a restart it is sent the value set before;
    /// after a `ParamSet` a different value means it refused, and its value is taken.
    /// `answered` names the oldest set the owner was waited on for: an owner handles its sets in
    /// order and declares after each, so a declaration refuses that one only — a later set still
    /// waiting (several sent at once, as calibration results are) is judged by a later one.
    fn redeclared(
        &mut self,
        i: usize,
        spec: ParamSpec,
        (start, answered): (bool, Option<&str>),
        now: Time,
        done: &mut Declared,
    ) {
        if let Some(at) = self.awaiting.iter().position(|a| a.name == spec.name) {
            let wanted = self.awaiting[at].wanted;
            if spec.value != wanted && answered != Some(spec.name.as_str()) {
                self.entries[i].spec = ParamSpec { value: self.entries[i].spec.value, ..spec };
                return;
            }
            let restored = self.awaiting.remove(at).restored;
            let entry = &mut self.entries[i];
            let previous = (entry.spec.value, entry.persist);
            entry.spec = spec;
            if entry.spec.value == wanted {
                entry.persist = true;
                if !restored {
                    done.persist_changed = true;
                    self.echo_when_saved(i, previous, &mut done.out.mav);
                }
                return;
            }
            let text = format!(
                "Param {}: refused by {}, keeps {}",
                entry.spec.name,
                entry.owner_name(),
                entry.spec.value
            );
            done.out.mav.push(statustext(MavSeverity::MAV_SEVERITY_WARNING, &text));
            done.out.mav.extend(self.value_msg(i));
            return;
        }
        let entry = &mut self.entries[i];
        let held = entry.spec.value;
        let declared = spec.value;
        entry.spec = spec;
        let persist = entry.persist;
        if held == declared {
            return;
        }
        if start && persist {
            self.want(i, held, now, done);
            return;
        }
        if persist {
            let entry = &self.entries[i];
            let text =
                format!("Param {}: refused by {}, keeps {declared}", entry.spec.name, entry.owner_name());
            done.out.mav.push(statustext(MavSeverity::MAV_SEVERITY_WARNING, &text));
            done.persist_changed = true;
        }
        done.out.mav.extend(self.value_msg(i));
    }

    /// Asks the owner of parameter `i` to take `value` (stored or set before), if in range.
    fn want(&mut self, i: usize, value: f64, now: Time, done: &mut Declared) {
        let entry = &mut self.entries[i];
        if !in_range(&entry.spec, value) {
            let s = &entry.spec;
            let text =
                format!("Param {}: stored {value} outside {}..{} {}; dropped", s.name, s.min, s.max, s.unit);
            done.out.mav.push(statustext(MavSeverity::MAV_SEVERITY_WARNING, &text));
            done.persist_changed = true;
            return;
        }
        entry.persist = true;
        let value = quantise(entry.spec.kind, value);
        if value != entry.spec.value {
            entry.spec.value = value;
            let name = entry.spec.name.clone();
            // Waited on like a set, so the answer to an earlier one of several is no refusal.
            self.awaiting.retain(|a| a.name != name);
            self.awaiting.push(Awaiting {
                name: name.clone(),
                wanted: value,
                deadline: now + CONFIRM_TIMEOUT,
                restored: true,
            });
            done.out.graph.push(ToGraph::Param(ParamSet { time: now, name, value, restore: true }));
        }
    }

    fn value_msg(&self, index: usize) -> Option<MavMessage> {
        let s = &self.entries.get(index)?.spec;
        Some(MavMessage::PARAM_VALUE(PARAM_VALUE_DATA {
            param_value: s.value as f32,
            param_count: u16::try_from(self.entries.len()).unwrap_or(u16::MAX),
            param_index: u16::try_from(index).unwrap_or(u16::MAX),
            param_id: s.name.as_str().into(),
            param_type: match s.kind {
                ParamKind::Real32 => MavParamType::MAV_PARAM_TYPE_REAL32,
                ParamKind::Int32 => MavParamType::MAV_PARAM_TYPE_INT32,
                ParamKind::Uint8 => MavParamType::MAV_PARAM_TYPE_UINT8,
            },
        }))
    }

    /// PARAM_REQUEST_LIST: the first [`PARAMS_PER_TICK`] parameters now, the rest from
    /// `on_tick` (a new request starts over).
    pub fn request_list(&mut self) -> Vec<MavMessage> {
        self.list_cursor = Some(0);
        self.next_chunk()
    }

    fn next_chunk(&mut self) -> Vec<MavMessage> {
        let Some(start) = self.list_cursor else { return Vec::new() };
        let end = (start + PARAMS_PER_TICK).min(self.entries.len());
        self.list_cursor = (end < self.entries.len()).then_some(end);
        (start..end).filter_map(|i| self.value_msg(i)).collect()
    }

    /// Every parameter, in index order.
    pub fn list(&self) -> Vec<MavMessage> {
        (0..self.entries.len()).filter_map(|i| self.value_msg(i)).collect()
    }

    /// PARAM_REQUEST_READ: by index when `index >= 0`, else by name. Unknown: nothing.
    pub fn read(&self, name: &str, index: i16) -> Option<MavMessage> {
        let i = match usize::try_from(index) {
            Ok(i) => i,
            Err(_) => self.entries.iter().position(|e| e.spec.name == name)?,
        };
        self.value_msg(i)
    }

    /// True once after each change the parameter file must follow.
    pub fn take_changed(&mut self) -> bool {
        std::mem::take(&mut self.changed)
    }

    /// PARAM_SET.
    pub fn set(&mut self, name: &str, value: f32, now: Time) -> Outputs {
        let Some(i) = self.entries.iter().position(|e| e.spec.name == name) else {
            let text = format!("Param {name}: unknown");
            return Outputs::send(statustext(MavSeverity::MAV_SEVERITY_WARNING, &text));
        };
        let value = f64::from(value);
        let entry = &mut self.entries[i];
        let spec = &mut entry.spec;
        let refusal = if self.armed && entry.disarmed_only {
            // Checked first: while armed no value of it is taken, whatever it is.
            Some(format!("{name}: cannot change while armed"))
        } else if !in_range(spec, value) {
            Some(format!("Param {name}: {value} outside {}..{} {}", spec.min, spec.max, spec.unit))
        } else if spec.kind != ParamKind::Real32 && value.fract() != 0.0 {
            // An integer parameter (a switch, an index) is not rounded into one of its values.
            Some(format!("Param {name}: {value} is not a whole number"))
        } else {
            None
        };
        if let Some(text) = refusal {
            let mut out = Outputs::send(statustext(MavSeverity::MAV_SEVERITY_WARNING, &text));
            out.mav.extend(self.value_msg(i));
            return out;
        }
        let value = quantise(spec.kind, value);
        let set = ParamSet { time: now, name: spec.name.clone(), value, restore: false };
        if entry.owner.is_some() {
            self.awaiting.retain(|a| a.name != set.name);
            self.awaiting.push(Awaiting {
                name: set.name.clone(),
                wanted: value,
                deadline: now + CONFIRM_TIMEOUT,
                restored: false,
            });
            self.changed = true;
            return Outputs { mav: Vec::new(), graph: vec![ToGraph::Param(set)] };
        }
        self.changed = true;
        let previous = (spec.value, entry.persist);
        spec.value = value;
        entry.persist = true;
        let mut out = Outputs { mav: Vec::new(), graph: vec![ToGraph::Param(set)] };
        self.echo_when_saved(i, previous, &mut out.mav);
        out
    }

    /// The next part of a parameter list being streamed, and the sets whose owner did not
    /// answer in time: the old value stays, and is echoed with why.
    fn tick(&mut self, now: Time) -> Vec<MavMessage> {
        let mut out = self.next_chunk();
        let (expired, waiting): (Vec<_>, Vec<_>) =
            std::mem::take(&mut self.awaiting).into_iter().partition(|a| now >= a.deadline);
        self.awaiting = waiting;
        for a in expired {
            let Some(i) = self.entries.iter().position(|e| e.spec.name == a.name) else { continue };
            let e = &self.entries[i];
            let text = format!(
                "Param {}: {} did not take {}; keeps {}",
                a.name,
                e.owner_name(),
                a.wanted,
                e.spec.value
            );
            out.push(statustext(MavSeverity::MAV_SEVERITY_WARNING, &text));
            out.extend(self.value_msg(i));
        }
        out
    }
}

impl Entry {
    fn owner_name(&self) -> &str {
        self.owner.as_deref().unwrap_or("the link")
    }
}

fn in_range(spec: &ParamSpec, value: f64) -> bool {
    value.is_finite()
        && value >= spec.min
        && value <= spec.max
        && match spec.kind {
            ParamKind::Real32 => true,
            ParamKind::Int32 => value >= f64::from(i32::MIN) && value <= f64::from(i32::MAX),
            ParamKind::Uint8 => (0.0..=255.0).contains(&value),
        }
}

fn quantise(kind: ParamKind, value: f64) -> f64 {
    match kind {
        ParamKind::Real32 => f64::from(value as f32),
        ParamKind::Int32 | ParamKind::Uint8 => value.round(),
    }
}

/// The parameter protocol: PARAM_REQUEST_LIST (streamed over ticks), PARAM_REQUEST_READ and
/// PARAM_SET; ticks also expire sets whose owner did not confirm.
impl Service for ParamTable {
    fn on_message(&mut self, _from: Sender, msg: &MavMessage, now: Time) -> Option<Outputs> {
        Some(match msg {
            MavMessage::PARAM_REQUEST_LIST(_) => Outputs { mav: self.request_list(), graph: Vec::new() },
            MavMessage::PARAM_REQUEST_READ(r) => {
                let name = r.param_id.to_str().unwrap_or_default().trim_end_matches('\0');
                Outputs { mav: self.read(name, r.param_index).into_iter().collect(), graph: Vec::new() }
            }
            MavMessage::PARAM_SET(s) => {
                let name = s.param_id.to_str().unwrap_or_default().trim_end_matches('\0').to_owned();
                self.set(&name, s.param_value, now)
            }
            _ => return None,
        })
    }

    fn on_tick(&mut self, now: Time) -> Outputs {
        Outputs { mav: self.tick(now), graph: Vec::new() }
    }
}

#[cfg(test)]
mod tests;
