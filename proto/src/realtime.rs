//! Real-time scheduling for the calling thread: SCHED_FIFO where the OS grants it (root or
//! `CAP_SYS_NICE`, or an `rtprio` limit), otherwise the thread stays a normal one and says so.
//! The controller's loop, the runtime threads of flight-critical actors (`priority` in the
//! graph) and the HIL world all ask here, so the policy and its refusal read the same.

/// What the calling thread got.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RealtimePriority {
    /// SCHED_FIFO at this priority (1..=99).
    Fifo(i32),
    /// A normal thread, and why.
    Normal(String),
}

/// Asks for SCHED_FIFO at `priority` (clamped to 1..=99) for the calling thread.
#[cfg(target_os = "linux")]
pub fn set_realtime_priority(priority: i32) -> RealtimePriority {
    let priority = priority.clamp(1, 99);
    let param = libc::sched_param { sched_priority: priority };
    // SAFETY: `sched_setscheduler` with pid 0 changes only the calling thread's policy and reads
    // `param`, a valid, initialised struct that outlives the call.
    let rc = unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO, &param) };
    if rc == 0 {
        RealtimePriority::Fifo(priority)
    } else {
        RealtimePriority::Normal(format!("SCHED_FIFO refused: {}", std::io::Error::last_os_error()))
    }
}

/// Asks for SCHED_FIFO at `priority`; not available on this OS.
#[cfg(not(target_os = "linux"))]
pub fn set_realtime_priority(_priority: i32) -> RealtimePriority {
    RealtimePriority::Normal("SCHED_FIFO is Linux-only".into())
}
