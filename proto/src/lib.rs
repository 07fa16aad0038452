//! Kestrel's contract: the messages actors exchange, the time and frame conventions they share,
//! and the [`Actor`] trait with the handles an actor is given.
//!
//! Conventions every message follows:
//! * SI units, spelled in field names where they could be confused (`gyro_rad_s`, `alt_msl_m`).
//! * Earth frame NED (north, east, down) around the home position; body frame FRD (forward,
//!   right, down). Quaternions are `[w, x, y, z]` and rotate body FRD vectors into NED.
//! * Every sample carries the [`Time`] it was *measured*, never the time it arrived.
//!
//! Actor crates depend on this crate and on nothing of each other; the runtime (the `kestrel`
//! crate) implements the mailboxes, router, clocks and supervisor behind these traits.

pub mod actor;
pub mod attitude;
/// Mutations of valid files for the property tests of every parser (test builds only).
#[cfg(any(test, feature = "testing"))]
pub mod bad_input;
pub mod bus;
pub mod calibration;
pub mod clock;
pub mod esc;
pub mod frame_layout;
pub mod geo;
pub mod keepsake;
pub mod message;
pub mod messages;
pub mod param_def;
pub mod percentiles;
pub mod realtime;
pub mod speed_cap;
#[cfg(any(test, feature = "testing"))]
pub mod testing;
pub mod time;
pub mod timing;
pub mod units;
pub mod wind;

pub use actor::{Actor, ActorError, Context, Publisher, Setup, Sink};
pub use clock::Clock;
pub use keepsake::Keepsake;
pub use message::Message;
pub use time::Time;
