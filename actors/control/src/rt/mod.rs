//! The real-time side of the control loop: the dedicated thread, the lock-free hand-over of
//! inputs, and its timing record.

mod loop_stats;
mod priority;
mod thread;
mod triple_buffer;

pub use loop_stats::{Histogram, LoopStats};
pub use priority::{RealtimePriority, set_realtime_priority};
pub use thread::{ControlThread, ThreadInputs, ThreadOutput};
pub use triple_buffer::{Reader, Writer, triple_buffer};
