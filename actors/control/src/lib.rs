//! Kestrel's flight control: the controller cores (position → attitude on SO(3) → body rate →
//! mixer), the commander (arming, modes, missions, failsafes) and the actors that run them.
//!
//! Frames follow `kestrel-proto`: NED earth frame around home, FRD body frame, quaternions
//! rotating FRD into NED. The cores are pure and synchronous; the closed-loop tests drive them
//! against the `kestrel-sim` core directly.
//!
//! Where to look:
//! * the cascade — [`position`] (PX4-style position/velocity loops), [`attitude`] (SO(3)
//!   error, tilt-first), [`rate`] (body-rate PID), [`mixer`] (allocation with desaturation),
//!   composed per iteration by [`flight_controller`]; [`flip`] is the aerobatic manoeuvre;
//!   [`backup_attitude`] is the complementary filter flown when the estimator is gone;
//! * the commander — [`commander`] (modes, arming, failsafes, land detector, missions, and
//!   who is in control: [`commander::PilotInput`], the receiver against a ground station's
//!   sticks and `MAV_GCS_SYSID`) and [`plan`] (QGroundControl `.plan` files);
//! * running it — [`rt`] (real-time thread, triple buffer, loop statistics),
//!   [`controller_actor`] and [`commander_actor`] (the actor shells, with their ports);
//!   [`pilot_script`] is a pilot on a timetable for deterministic simulated flights.
//!
//! Two actors rather than one: the loop must never wait, and on hardware it lives on its own
//! real-time thread, while the commander does slow, allocating work (missions, strings for
//! refusals, logs) at a lower rate; separate actors also let the supervisor restart the
//! commander without touching the loop, whose own failsafes (blind flight, lost setpoint)
//! cover the gap.

pub mod airframe;
pub mod attitude;
pub mod backup_attitude;
pub mod commander;
pub mod commander_actor;
pub mod controller_actor;
pub mod error;
pub mod flight_controller;
pub mod flip;
pub mod live_params;
pub mod mixer;
pub mod motor_failure;
pub mod params;
pub mod pilot_script;
pub mod plan;
pub mod position;
pub mod rate;
pub mod rt;
pub mod spin_descent;
pub mod truth_nav;

pub use airframe::AirframeParams;
pub use attitude::{AttitudeController, AttitudeGains, attitude_error};
pub use backup_attitude::{BackupAttitude, BackupAttitudeParams, ImuReading};
pub use commander::{Commander, CommanderParams, Refusal};
pub use commander_actor::{CommanderActor, CommanderActorParams, CommanderInput};
pub use controller_actor::{ControllerActor, ControllerActorParams, ControllerInput, LoopMode};
pub use error::{InvalidParam, PlanError, RejectedInput};
pub use flight_controller::{Demand, FlightController, LoopCounters};
pub use flip::Flip;
pub use live_params::{Gains, Tuning};
pub use mixer::{Mixer, MixerOutput, Saturation};
pub use params::{ControlParams, LoopParams};
pub use pilot_script::{PilotScriptActor, PilotScriptInput, PilotScriptParams, PilotStep};
pub use plan::{load_plan, parse_plan};
pub use position::{AttitudeThrust, PositionController, PositionGains};
pub use rate::{RateController, RateGains};
pub use spin_descent::{SpinDescent, SpinInputError, SpinOutput};
pub use truth_nav::{TruthNavActor, TruthNavInput, TruthNavParams};
