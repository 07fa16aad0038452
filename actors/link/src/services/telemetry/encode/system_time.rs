//! SYSTEM_TIME: the time since boot, and the UTC time when the graph knows it.

use mavlink::dialects::ardupilotmega::SYSTEM_TIME_DATA;

/// SYSTEM_TIME at `boot_ms` (ms since boot). `time_unix_usec` is 0, MAVLink's "unknown": no
/// topic of the graph carries UTC (the GPS fix is stamped on the graph's monotonic clock), and
/// a ground station must not set its clock from a guess.
pub fn system_time(boot_ms: u32) -> SYSTEM_TIME_DATA {
    SYSTEM_TIME_DATA { time_unix_usec: 0, time_boot_ms: boot_ms }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn boot_time_advances_and_utc_is_unknown() {
        let (a, b) = (system_time(1_000), system_time(1_250));
        assert!(b.time_boot_ms > a.time_boot_ms);
        assert_eq!(a.time_unix_usec, 0);
    }
}
