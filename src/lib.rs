//! Kestrel's runtime: mailboxes, topics, the router that wires actors from the config, the
//! supervisor, clocks (monotonic and lockstep), the flight-log recorder, and the CLI's pieces.

pub mod recorder;
