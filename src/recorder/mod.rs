//! Flight-log recorder (MCAP).
