//! Kestrel's runtime: mailboxes, topics, the router that wires actors from the config, the
//! supervisor, clocks (monotonic and lockstep), the flight-log recorder, and the CLI's pieces.
//!
//! Where to look — what runs in flight:
//! * a run from start to end — [`run`](mod@run) (build the graph, spawn every actor under its supervisor,
//!   drive the clock, shut down), [`shutdown`] (a signal lands an armed vehicle before the run
//!   ends), [`service_manager`] (systemd's notify protocol), [`locks`] (one process per
//!   instance and per device);
//! * wiring — [`config`] and [`compose`] (TOML graphs with `extends`), [`vehicle`] (the one
//!   vehicle file the simulator flies and the controller controls), [`registry`] (actor type
//!   names), [`graph`] (topics, mailboxes, the ports each actor declares), [`topic`] and
//!   [`mailbox`] (`queue` and `latest`), [`activity`] (what lockstep waits for);
//! * time and failure — [`clock`] (monotonic and lockstep), [`supervisor`] (restarts, escalation
//!   to the commander), [`fault_injection`] (`actor_panic` faults), [`hil`] (`--hil`: the Navio2
//!   graph on emulated devices);
//! * what a flight leaves — [`recorder`] (MCAP), [`flight_report`] with [`estimator_events`],
//!   [`attitude_source`] and [`frame_latency`] (the `--report` JSON), [`status`] (the 1 Hz line).
//!
//! And the tools around it: [`replay`] and [`log_replay`] (the estimator over a recorded log),
//! [`flight_log`] (reading our MCAP and PX4 ULog), [`flight_plots`] (`kestrel report`),
//! [`side_by_side`] (one flight by Kestrel and by ArduCopter SITL, scored alike: `kestrel sitl
//! compare`),
//! [`serde_name`] (names for display). The command line itself is `src/main.rs` and `src/cmd/`.

pub mod activity;
pub mod attitude_source;
pub mod clock;
pub mod compose;
pub mod config;
pub mod estimator_events;
pub mod fault_injection;
pub mod flight_log;
pub mod flight_plots;
pub mod flight_report;
pub mod frame_latency;
pub mod graph;
pub mod graph_drawing;
pub mod hil;
pub mod locks;
pub mod log_replay;
pub mod mailbox;
pub mod reboot;
pub mod recorder;
pub mod registry;
pub mod replay;
pub mod run;
pub mod serde_name;
pub mod service_manager;
pub mod shutdown;
pub mod side_by_side;
pub mod status;
pub mod supervisor;
pub mod topic;
pub mod vehicle;

pub use config::LoadedConfig;
pub use registry::Registry;
pub use run::{RunError, RunOptions, RunReport, run, topic_wiring, unwired_parameters};
