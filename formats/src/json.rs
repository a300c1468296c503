//! Reading and writing the JSON files of the contract.

use std::path::Path;

use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::atomic::write_atomic;
use crate::{FormatError, Result};

/// Read and parse a JSON file; errors name the file, line and column.
pub fn read_json<T: DeserializeOwned>(path: &Path) -> Result<T> {
    let text = std::fs::read_to_string(path).map_err(|e| FormatError::io(path, e))?;
    if text.trim().is_empty() {
        return Err(FormatError::file(path, "the file is empty"));
    }
    serde_json::from_str(&text).map_err(|e| FormatError::file(path, e.to_string()))
}

/// Write a value as pretty JSON, atomically, replacing an existing file
/// (commands write their outputs through an [`crate::OutputPlan`]).
pub fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    write_atomic(path, &to_bytes(path, value)?)
}

/// A value as pretty JSON with a final newline; errors name `path`.
pub(crate) fn to_bytes<T: Serialize>(path: &Path, value: &T) -> Result<Vec<u8>> {
    let mut text =
        serde_json::to_vec_pretty(value).map_err(|e| FormatError::file(path, e.to_string()))?;
    text.push(b'\n');
    Ok(text)
}
