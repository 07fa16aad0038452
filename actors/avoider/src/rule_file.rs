//! Loading a rule base from a file, choosing the format by extension (`.fll` or `.toml`).
//! This is the only place the crate touches the file system; the engine never does.

use std::path::Path;

use crate::engine::Engine;
use crate::error::LoadError;
use crate::{fll, toml_format};

/// Reads and validates the rule base at `path`.
pub fn load(path: &Path) -> Result<Engine, LoadError> {
    let extension = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let parse = match extension.as_deref() {
        Some("fll") => fll::parse,
        Some("toml") => toml_format::parse,
        _ => {
            return Err(LoadError::UnknownFormat { path: path.to_path_buf() });
        }
    };
    let text =
        std::fs::read_to_string(path).map_err(|source| LoadError::Io { path: path.to_path_buf(), source })?;
    parse(&text, &path.display().to_string())
}
