//! Value parsers of numeric options: an option's domain is checked while the
//! command line is parsed, so a value outside it is a usage error (exit status
//! 2) naming the option, before any file is read.

use std::str::FromStr;

/// Parse a number and check it against its domain.
fn number<T>(s: &str, ok: impl Fn(&T) -> bool, domain: &str) -> Result<T, String>
where
    T: FromStr + Copy,
    T::Err: std::fmt::Display,
{
    let v: T = s
        .trim()
        .parse()
        .map_err(|e| format!("expected {domain}: {e}"))?;
    if ok(&v) {
        Ok(v)
    } else {
        Err(format!("expected {domain}"))
    }
}

/// A finite number.
pub fn finite(s: &str) -> Result<f64, String> {
    number(s, |v: &f64| v.is_finite(), "a finite number")
}

/// A finite number greater than zero.
pub fn positive(s: &str) -> Result<f64, String> {
    number(
        s,
        |v: &f64| v.is_finite() && *v > 0.0,
        "a finite number > 0",
    )
}

/// A finite number greater than zero, single precision.
pub fn positive_f32(s: &str) -> Result<f32, String> {
    number(
        s,
        |v: &f32| v.is_finite() && *v > 0.0,
        "a finite number > 0",
    )
}

/// A finite number of zero or more.
pub fn non_negative(s: &str) -> Result<f64, String> {
    number(
        s,
        |v: &f64| v.is_finite() && *v >= 0.0,
        "a finite number ≥ 0",
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn domains() {
        assert_eq!(positive("2.5"), Ok(2.5));
        for bad in ["0", "-1", "nan", "inf", "x", ""] {
            assert!(positive(bad).is_err(), "{bad}");
        }
        assert_eq!(non_negative("0"), Ok(0.0));
        assert!(non_negative("-0.5").unwrap_err().contains("≥ 0"));
        assert_eq!(finite("-1e3"), Ok(-1000.0));
        assert!(finite("inf").is_err());
        assert_eq!(positive_f32("1"), Ok(1.0));
        assert!(positive_f32("NaN").is_err());
    }
}
