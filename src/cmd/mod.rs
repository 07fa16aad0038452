//! One module per subcommand.

pub mod calibrate;
pub mod disparity;
pub mod fuzzy;
pub mod replay;
pub mod report;
pub mod run;
pub mod sitl;
pub mod stereo;
