//! The commander's state machine without physics, by theme; what the themes share is in
//! `fixtures`.

mod arming;
mod avoidance;
mod estimator;
mod failsafes;
mod fence;
pub(crate) mod fixtures;
mod guided;
mod home;
mod landing;
mod mission;
mod modes;
mod motors;
mod poshold_avoidance;
mod rally;
mod rtl;
mod vertical;

pub(crate) use fixtures::{at, hovering, nav, ready};
