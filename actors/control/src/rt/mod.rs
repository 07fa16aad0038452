//! The real-time side of the control loop: the dedicated thread, the lock-free hand-over of
//! inputs and outputs, and its timing record.

mod affinity;
mod loop_stats;
mod memory;
mod sample_ring;
mod thread;
mod triple_buffer;

pub use affinity::pin_to_cpu;
pub use loop_stats::{Histogram, LoopStats};
pub use memory::lock_memory;
pub use sample_ring::{RingReader, RingWriter, sample_ring};
pub use thread::{
    ControlThread, Granted, LoopSample, RealtimeSettings, ThreadInputs, ThreadOutput, WATCHDOG_PERIODS,
};
pub use triple_buffer::{Reader, Writer, triple_buffer};
