//! Fault injection: what a world file's `[[faults]]` array breaks, and when.
//!
//! A [`Fault`] is one entry: it starts at `at_s` seconds of simulated time (the graph clock,
//! zero at the start of the run) and lasts `for_s` seconds, or to the end of the run when
//! `for_s` is omitted. A [`FaultSchedule`] answers which faults are active at a time
//! ([`FaultSchedule::active_at`]), sums them into the [`FaultEffects`] each model applies to its
//! own output (the GPS in `sensors/gps.rs`, the motors in `motors.rs`, ...), and reports each
//! start and end once ([`FaultSchedule::poll`]) for the log and the `sim_fault` topic. Later the
//! live simulator parameters and MAV_CMD_INJECT_FAILURE add entries to the same schedule
//! ([`FaultSchedule::push`]).
//!
//! Time is integer microseconds like the rest of the simulator: a fault is active on every tick
//! `t` with `start ≤ t < end`, `start = round(at_s·10⁶) µs`. A tick's physics (motors, wind) and
//! its sensor samples both see the faults active at the tick's time.
//!
//! Overlapping faults combine as the physics would: offsets and biases add, factors multiply,
//! switches (off, stuck, stop) hold while any is active; a later `wind` replaces an earlier one
//! (the latest start wins; on a tie, the later entry).
//!
//! Where to look: `kind.rs` holds what a fault is and checks its values, `entry.rs` reads a world
//! file's `[[faults]]` table (and names the line and field of a bad entry), `schedule.rs` answers
//! what is active when and what it does to each model.

mod entry;
mod kind;
mod schedule;

pub(crate) use entry::{check_entries, check_for_vehicle};
pub use entry::{entry_lines, fault_of_message};
pub use kind::{CameraLens, Fault, FaultKind, KINDS};
pub use schedule::{CameraFaults, FaultEffects, FaultEvent, FaultSchedule, Glare};
