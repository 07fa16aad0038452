//! PARAM_VALUE once the value is on disk. With a parameter file (`hold_echoes_until_saved`), the
//! echo of an accepted set waits for the write of a file that holds it: a ground station is told
//! a value is set only when a restart would keep it. A write that fails puts back the value the
//! file still holds (the owner is sent it again), echoes that value and says why in a STATUSTEXT
//! (`Param RTL_ALT_M not saved: read-only`), so the ground station shows what the vehicle uses
//! and will use after a restart; the file is then rewritten from the table, as a later write
//! that was rendered before the failure holds the failed value too. Held by
//! `a_set_is_echoed_only_after_the_file_holds_it` and `a_failed_write_echoes_the_old_value_with_why`
//! (`params/tests.rs`) and by `tests/gcs_param_storage.rs` on a read-only directory.

use kestrel_proto::Time;
use kestrel_proto::messages::ParamSet;
use mavlink::dialects::ardupilotmega::{MavMessage, MavSeverity};

use super::{Awaiting, CONFIRM_TIMEOUT, ParamTable, render_param_file};
use crate::services::events::statustext;
use crate::services::{Outputs, ToGraph};

/// A change taken and not yet known to be on disk.
#[derive(Debug)]
pub(super) struct Unsaved {
    name: String,
    /// The value set: echoed once a file holding it is written.
    value: f64,
    /// What the parameter was before (the file's value when this is the oldest change of it),
    /// and whether the file held it: put back when the write fails.
    previous: f64,
    previous_persist: bool,
    /// The write whose text holds the change (`None`: not rendered yet).
    batch: Option<u64>,
}

/// A parameter file text to write, numbered so its outcome finds the changes it holds.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamWrite {
    pub batch: u64,
    pub text: String,
}

impl ParamTable {
    /// From now on a set is echoed only when a file holding it is written ([`ParamTable::on_saved`]).
    pub fn hold_echoes_until_saved(&mut self) {
        self.hold_echoes = true;
    }

    /// Echoes parameter `i`'s accepted value now, or once saved when echoes are held.
    pub(super) fn echo_when_saved(&mut self, i: usize, previous: (f64, bool), out: &mut Vec<MavMessage>) {
        if !self.hold_echoes {
            out.extend(self.value_msg(i));
            return;
        }
        let spec = &self.entries[i].spec;
        self.unsaved.push(Unsaved {
            name: spec.name.clone(),
            value: spec.value,
            previous: previous.0,
            previous_persist: previous.1,
            batch: None,
        });
    }

    /// The file text to write after a change, once per change; the held echoes it covers wait
    /// for its outcome.
    pub fn take_write(&mut self) -> Option<ParamWrite> {
        if !self.take_changed() {
            return None;
        }
        self.next_batch += 1;
        let batch = self.next_batch;
        for u in self.unsaved.iter_mut().filter(|u| u.batch.is_none()) {
            u.batch = Some(batch);
        }
        Some(ParamWrite { batch, text: render_param_file(self) })
    }

    /// The write of `batch` ended (`Err` names why, short). Success echoes every change it and
    /// the writes it replaced held; failure puts each changed parameter back (module docs).
    pub fn on_saved(&mut self, batch: u64, result: Result<(), &str>, now: Time) -> Outputs {
        let (done, later): (Vec<_>, Vec<_>) =
            std::mem::take(&mut self.unsaved).into_iter().partition(|u| u.batch.is_some_and(|b| b <= batch));
        self.unsaved = later;
        let mut out = Outputs::none();
        let Err(reason) = result else {
            for u in done {
                let Some(i) = self.entries.iter().position(|e| e.spec.name == u.name) else { continue };
                out.mav.extend(self.value_msg(i).map(|m| with_value(m, u.value)));
            }
            return out;
        };
        let mut reverted: Vec<String> = Vec::new();
        // Oldest first: the oldest change of a parameter knows the value the file holds.
        for u in done {
            if reverted.contains(&u.name) {
                continue;
            }
            let Some(i) = self.entries.iter().position(|e| e.spec.name == u.name) else { continue };
            reverted.push(u.name.clone());
            // A later change of it, still waiting, now follows the value put back.
            for later in self.unsaved.iter_mut().filter(|l| l.name == u.name) {
                (later.previous, later.previous_persist) = (u.previous, u.previous_persist);
            }
            let entry = &mut self.entries[i];
            entry.persist = u.previous_persist;
            if entry.spec.value != u.previous {
                entry.spec.value = u.previous;
                if entry.owner.is_some() {
                    // The owner took the new value: it is sent the old one, as a stored value
                    // (no echo of its answer).
                    self.awaiting.retain(|a| a.name != u.name);
                    self.awaiting.push(Awaiting {
                        name: u.name.clone(),
                        wanted: u.previous,
                        deadline: now + CONFIRM_TIMEOUT,
                        restored: true,
                    });
                    out.graph.push(ToGraph::Param(ParamSet {
                        time: now,
                        name: u.name.clone(),
                        value: u.previous,
                        restore: true,
                    }));
                }
            }
            let text = format!("Param {} not saved: {reason}", u.name);
            out.mav.push(statustext(MavSeverity::MAV_SEVERITY_ERROR, &text));
            out.mav.extend(self.value_msg(i));
        }
        // A write rendered before this outcome may hold a value just put back: write again.
        self.changed |= !reverted.is_empty();
        out
    }
}

/// `msg` (a PARAM_VALUE) carrying `value`: the one the saved file holds.
fn with_value(msg: MavMessage, value: f64) -> MavMessage {
    match msg {
        MavMessage::PARAM_VALUE(mut p) => {
            p.param_value = value as f32;
            MavMessage::PARAM_VALUE(p)
        }
        other => other,
    }
}

/// A write error in a few words for a STATUSTEXT (the log has it whole).
pub fn short_reason(error: &std::io::Error) -> &'static str {
    use std::io::ErrorKind;
    match error.kind() {
        ErrorKind::ReadOnlyFilesystem => "read-only",
        ErrorKind::StorageFull | ErrorKind::QuotaExceeded => "disk full",
        ErrorKind::PermissionDenied => "no permission",
        ErrorKind::NotFound => "no directory",
        _ => "write error",
    }
}
