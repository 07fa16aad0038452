//! Sensor calibration cores: pure fits from recorded samples to the calibrations of
//! `kestrel_proto::calibration`, each with its quality figures or a typed refusal saying why
//! the data cannot support it. No I/O: the ground-station-driven shell feeds them.
//!
//! * [`mag`] — compass hard and soft iron by ellipsoid fit, with [`coverage`] of the sphere;
//! * [`accel`] — six-orientation offsets and scales;
//! * [`gyro`] — gyro offset at rest;
//! * [`level`] — the board's roll and pitch against the airframe;
//! * [`esc`] — each output's pulse range from a recorded ramp, driven by [`esc_ramp`];
//! * [`session`] — one ground-station-driven calibration at a time, over the fits above;
//! * [`still`] — the at-rest check the last three share.

pub mod accel;
pub mod coverage;
pub mod esc;
pub mod esc_ramp;
pub mod gyro;
pub mod level;
pub mod mag;
pub mod session;
pub mod still;

pub use accel::{
    AccelCalError, AccelFit, AccelSettings, OrientationSamples, VehicleOrientation, calibrate_accel,
};
pub use esc::{EscCalError, EscRange, EscSample, EscSettings, calibrate_esc};
pub use esc_ramp::{EscRamp, InvalidRamp};
pub use gyro::{GyroCalError, GyroFit, GyroSettings, calibrate_gyro};
pub use level::{LevelCalError, LevelFit, LevelSettings, calibrate_level};
pub use mag::{MagCalError, MagFit, MagSettings, calibrate_mag};
pub use session::{Session, SessionSettings};
pub use still::{NotStill, StillLimits, StillWindow};
