//! Loading a TOML config file into a typed, validated value: the simulator's only I/O.

use std::path::Path;

use serde::de::DeserializeOwned;

use crate::error::{ConfigError, InvalidParam};

/// Reads and parses `path`, then runs `validate`; every failure names the file.
pub(crate) fn load<T: DeserializeOwned>(
    path: &Path,
    validate: impl FnOnce(&T) -> Result<(), InvalidParam>,
) -> Result<T, ConfigError> {
    let text = std::fs::read_to_string(path)
        .map_err(|source| ConfigError::Read { path: path.to_path_buf(), source })?;
    let value: T =
        toml::from_str(&text).map_err(|source| ConfigError::Parse { path: path.to_path_buf(), source })?;
    validate(&value).map_err(|source| ConfigError::Invalid { path: path.to_path_buf(), source })?;
    Ok(value)
}
