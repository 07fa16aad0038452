//! One module per subcommand.

pub mod fuzzy;
pub mod replay;
pub mod run;
