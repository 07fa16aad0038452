//! Loading a TOML config file into a typed, validated value: the simulator's only I/O.

use std::path::Path;

use serde::de::DeserializeOwned;

use crate::error::{ConfigError, InvalidParam};

/// Reads and parses `path`, then runs `validate`; every failure names the file.
pub(crate) fn load<T: DeserializeOwned>(
    path: &Path,
    validate: impl FnOnce(&T) -> Result<(), InvalidParam>,
) -> Result<T, ConfigError> {
    parse(path, &read(path)?, validate)
}

/// The text of `path`.
pub(crate) fn read(path: &Path) -> Result<String, ConfigError> {
    std::fs::read_to_string(path).map_err(|source| ConfigError::Read { path: path.to_path_buf(), source })
}

/// Parses `text`, read from `path`, then runs `validate`; every failure names the file.
pub(crate) fn parse<T: DeserializeOwned>(
    path: &Path,
    text: &str,
    validate: impl FnOnce(&T) -> Result<(), InvalidParam>,
) -> Result<T, ConfigError> {
    let value: T =
        toml::from_str(text).map_err(|source| ConfigError::Parse { path: path.to_path_buf(), source })?;
    validate(&value).map_err(|source| ConfigError::Invalid { path: path.to_path_buf(), source })?;
    Ok(value)
}
