//! One module per subcommand.

pub mod fuzzy;
pub mod run;
