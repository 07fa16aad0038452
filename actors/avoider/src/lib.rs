//! Kestrel's fuzzy (Mamdani) inference engine and the thesis's obstacle-avoidance rule base.
//!
//! No Rust fuzzy crate is mature enough to fly, so the engine is ours. It follows fuzzylite
//! (the library the thesis ran on the Jetson, §3.3.8) closely enough that the same FLL file
//! gives the same numbers here and in pyfuzzylite, which the agreement tests check.
//!
//! * [`fll::parse`], [`toml_format::parse`], [`rule_file::load`] read a rule base and validate
//!   it into an [`Engine`], or say which line of which file is wrong and why ([`LoadError`]).
//! * [`Engine::infer`] runs one inference into a preallocated [`Workspace`]: no allocation.
//! * [`evaluation::evaluate`] is the `kestrel fuzzy` command's core: `NAME=VALUE` in,
//!   outputs and rule activations out.
//! * [`THESIS_RULE_BASE`] is the avoider's rule base (thesis table 3.1), as shipped in
//!   `config/avoider/thesis.fll`.
//! * [`Avoider`] is the avoider's pure core (depth grid and desired speed in, body-frame
//!   velocity correction out) and [`AvoiderActor`] its actor shell.
//! * [`SurroundSectors`] turns depth grids and the obstacle memory into full-surround
//!   `OBSTACLE_DISTANCE` sectors for a flight controller; [`ProximityActor`] is its shell.

mod actor;
pub mod avoidance;
mod build;
pub mod defuzzifier;
pub mod engine;
pub mod error;
pub mod evaluation;
pub mod fll;
pub mod hedge;
pub mod norms;
pub mod proximity;
pub mod rule;
pub mod rule_file;
mod spec;
pub mod term;
pub mod toml_format;
pub mod variable;

pub use actor::{AvoiderActor, AvoiderInput};
pub use avoidance::Avoider;
pub use avoidance::error::{AvoiderError, GridError, ParamsError, SetpointError};
pub use avoidance::params::AvoiderParams;
pub use defuzzifier::{Defuzzifier, IntegralMethod, WeightedKind, WeightedMethod};
pub use engine::{Engine, RuleBlock, Workspace};
pub use error::{Cause, InputError, LoadError};
pub use evaluation::{Evaluation, evaluate};
pub use hedge::Hedge;
pub use norms::{SNorm, TNorm};
pub use proximity::SurroundSectors;
pub use proximity::actor::{ProximityActor, ProximityInput};
pub use proximity::params::ProximityParams;
pub use term::{Shape, Term};
pub use variable::{InputVariable, OutputVariable};

/// The thesis's avoider rule base (table 3.1, last row corrected), the text of
/// `config/avoider/thesis.fll`, built in so the avoider can start without its config file.
pub const THESIS_RULE_BASE: &str = include_str!("../../../config/avoider/thesis.fll");

/// Builds the thesis's rule base from [`THESIS_RULE_BASE`].
pub fn thesis_engine() -> Result<Engine, LoadError> {
    fll::parse(THESIS_RULE_BASE, "config/avoider/thesis.fll")
}
