//! Kestrel's runtime: mailboxes, topics, the router that wires actors from the config, the
//! supervisor, clocks (monotonic and lockstep), the flight-log recorder, and the CLI's pieces.

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
pub mod hil;
pub mod locks;
pub mod log_replay;
pub mod mailbox;
pub mod recorder;
pub mod registry;
pub mod replay;
pub mod run;
pub mod serde_name;
pub mod service_manager;
pub mod shutdown;
pub mod status;
pub mod supervisor;
pub mod topic;

pub use config::LoadedConfig;
pub use registry::Registry;
pub use run::{RunError, RunOptions, RunReport, run, unwired_parameters};
