//! The machine-readable flight report (`kestrel run --report FILE.json`): did the mission
//! complete, did the vehicle hit anything, how far was the estimate from the truth, how
//! regular was the control loop, which failsafes fired, and which simulated faults were
//! injected when (the simulator's `sim_fault`), and what the estimator noticed when
//! (`estimator_status`, see [`crate::estimator_events`]), which actors the supervisor restarted
//! (`supervisor`), what the commander announced (its status's refusals and notices, each a
//! STATUSTEXT on the link), and which attitude flew — the estimator's or the controller's backup
//! (`backup_nav_state`, see [`crate::attitude_source`]) — and when it switched.
//!
//! Where to look: `schema.rs` is what a report holds (serde, the layout other tools read),
//! `scoring.rs` how each figure is computed from the messages, `actor.rs` the actor that feeds
//! the scoring from the graph's topics and writes the report when the run stops. Each section
//! is `null` when the part it scores did not run.

mod actor;
mod schema;
mod scoring;

pub use actor::{FlightReportActor, FlightReportParams, REPORT_INPUTS, ReportInput};
pub use schema::{
    ActorEventEntry, AvoidanceSection, ControlSection, EstimatorSection, FailsafeEntry, FaultEntry,
    FlightReport, FlightSection, MissionSection, MotorFailureEntry, NoticeEntry, Touchdown,
};
