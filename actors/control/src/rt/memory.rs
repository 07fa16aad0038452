//! Locking the process's memory into RAM for the real-time loop: `mlockall(MCL_CURRENT |
//! MCL_FUTURE)`, as ArduPilot's Linux scheduler does at start-up, so that no page the loop
//! touches is paged out and none it allocates later faults in on first touch (its loop
//! statistics are made after the lock, so they are resident from the start). Needs root,
//! `CAP_IPC_LOCK` or a large enough `memlock` limit; refused, the loop runs unlocked and says so.

/// Locks all current and future pages of the process; `Err` with the OS's reason if refused.
#[cfg(target_os = "linux")]
pub fn lock_memory() -> Result<(), String> {
    // SAFETY: mlockall takes flags only and changes no memory the program can see.
    let rc = unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) };
    if rc == 0 { Ok(()) } else { Err(format!("mlockall refused: {}", std::io::Error::last_os_error())) }
}

/// Locks all current and future pages of the process; not available on this OS.
#[cfg(not(target_os = "linux"))]
pub fn lock_memory() -> Result<(), String> {
    Err("mlockall is Linux-only".into())
}
