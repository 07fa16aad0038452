//! The side-by-side rows for tests: the flying and scoring live in `kestrel::side_by_side`
//! (what `kestrel sitl compare` runs); this gives them the test build's binaries and the
//! repository's Python venv.

use std::path::Path;

pub use kestrel::side_by_side::*;

use super::flights::repo;
use super::sim_vehicle::python;

/// The programs a row runs in a test: this build's `kestrel`, `arducopter` (from
/// `KESTREL_ARDUCOPTER`) and the venv's Python; the transcript is printed (`--nocapture`).
pub fn tools(arducopter: &Path) -> Tools {
    Tools {
        kestrel: env!("CARGO_BIN_EXE_kestrel").into(),
        arducopter: arducopter.to_path_buf(),
        python: python(),
        repo: repo().to_path_buf(),
        echo_transcript: true,
    }
}
