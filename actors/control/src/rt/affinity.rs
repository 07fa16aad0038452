//! Pinning the real-time loop to one CPU (`sched_setaffinity` for the calling thread), as
//! ArduPilot's Linux build does with `--cpu-affinity`: a core of its own (best isolated from the
//! kernel's scheduler with `isolcpus=`) keeps other threads from delaying it and its cache warm.
//! A CPU the machine does not have, or a refusal, leaves the thread unpinned, and says why.

/// Pins the calling thread to `cpu` (0-based); `Err` with the reason if it cannot be.
#[cfg(target_os = "linux")]
pub fn pin_to_cpu(cpu: usize) -> Result<(), String> {
    // SAFETY: sysconf only reads a system constant.
    let online = unsafe { libc::sysconf(libc::_SC_NPROCESSORS_ONLN) };
    if online > 0 && cpu >= online as usize {
        return Err(format!("CPU {cpu} requested, this machine has {online}"));
    }
    if cpu >= libc::CPU_SETSIZE as usize {
        return Err(format!("CPU {cpu} is beyond the {} a CPU set can name", libc::CPU_SETSIZE));
    }
    // SAFETY: a zeroed cpu_set_t is the empty set; CPU_SET writes inside it for cpu <
    // CPU_SETSIZE (checked above); sched_setaffinity with pid 0 changes only the calling
    // thread and reads the set, which outlives the call.
    let rc = unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        libc::CPU_SET(cpu, &mut set);
        libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set)
    };
    if rc == 0 {
        Ok(())
    } else {
        Err(format!("sched_setaffinity refused: {}", std::io::Error::last_os_error()))
    }
}

/// Pins the calling thread to `cpu`; not available on this OS.
#[cfg(not(target_os = "linux"))]
pub fn pin_to_cpu(_cpu: usize) -> Result<(), String> {
    Err("CPU pinning is Linux-only".into())
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::*;

    #[test]
    fn a_thread_is_pinned_to_a_cpu_it_has_and_refused_one_it_has_not() {
        let on_cpu0 = std::thread::spawn(|| {
            let pinned = pin_to_cpu(0);
            // SAFETY: sched_getcpu takes no arguments.
            (pinned, unsafe { libc::sched_getcpu() })
        })
        .join()
        .expect("thread");
        assert_eq!(on_cpu0, (Ok(()), 0));
        let refused = std::thread::spawn(|| pin_to_cpu(100_000)).join().expect("thread");
        assert!(refused.is_err_and(|why| why.contains("100000")), "an absent CPU is refused");
    }
}
