//! The checks every configuration table's `validate` is made of; each error
//! names the key (`key: message`).

use crate::{Result, SynthError};

/// A configuration error naming `key`.
pub(crate) fn bad(key: &str, message: impl std::fmt::Display) -> SynthError {
    SynthError::config(format!("{key}: {message}"))
}

pub(crate) fn positive(key: &str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(bad(key, format!("{v} must be a positive number")))
    }
}

pub(crate) fn non_negative(key: &str, v: f64) -> Result<()> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(bad(key, format!("{v} must be a finite number ≥ 0")))
    }
}

pub(crate) fn finite(key: &str, values: &[f64]) -> Result<()> {
    match values.iter().find(|v| !v.is_finite()) {
        Some(v) => Err(bad(key, format!("{v} is not a finite number"))),
        None => Ok(()),
    }
}
