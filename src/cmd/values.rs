//! Value parsers shared by the commands' flags: a bad value is a usage error
//! (exit status 2) naming the flag and the value, reported once by clap
//! before any work, never a NaN that fails every frame later.

/// A finite number (not NaN, not ±inf).
pub fn finite(text: &str) -> Result<f64, String> {
    let v: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("'{text}' is not a number"))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("{text} is not a finite number"))
    }
}

/// A finite number > 0.
pub fn positive(text: &str) -> Result<f64, String> {
    let v = finite(text)?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(format!("{v} must be a positive number"))
    }
}


/// A positive number as `f32` (within its range).
pub fn positive_f32(text: &str) -> Result<f32, String> {
    let v = positive(text)?;
    if v <= f64::from(f32::MAX) {
        Ok(v as f32)
    } else {
        Err(format!("{v} is too large"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn not_a_number_is_refused() {
        assert_eq!(finite("1.5"), Ok(1.5));
        assert_eq!(finite("-2"), Ok(-2.0));
        assert_eq!(finite("nan").unwrap_err(), "nan is not a finite number");
        assert_eq!(finite("inf").unwrap_err(), "inf is not a finite number");
        assert_eq!(finite("x").unwrap_err(), "'x' is not a number");
        assert_eq!(positive("0").unwrap_err(), "0 must be a positive number");
        assert!(positive_f32("1e300").is_err());
    }
}
