//! Value parsers of the commands' numeric options: an option's domain is
//! checked while the command line is parsed, so a value outside it is a usage
//! error (exit status 2) naming the option and the value, before any file is
//! read — never a NaN that fails every frame later.

use std::str::FromStr;

/// Parse a number and check it against its domain (`what` names the domain
/// in the message, e.g. "a positive number").
fn number<T>(text: &str, ok: impl Fn(&T) -> bool, what: &str) -> Result<T, String>
where
    T: FromStr + Copy + std::fmt::Display,
{
    let v: T = text
        .trim()
        .parse()
        .map_err(|_| format!("'{text}' is not a number"))?;
    if ok(&v) {
        Ok(v)
    } else {
        Err(format!("{v} is not {what}"))
    }
}

/// A finite number (not NaN, not ±inf).
pub fn finite(text: &str) -> Result<f64, String> {
    number(text, |v: &f64| v.is_finite(), "a finite number")
}

/// A finite number > 0.
pub fn positive(text: &str) -> Result<f64, String> {
    number(
        text,
        |v: &f64| v.is_finite() && *v > 0.0,
        "a positive finite number",
    )
}

/// A finite number > 0, single precision (within its range).
pub fn positive_f32(text: &str) -> Result<f32, String> {
    number(
        text,
        |v: &f32| v.is_finite() && *v > 0.0,
        "a positive finite number",
    )
}

/// A finite number ≥ 0.
pub fn non_negative(text: &str) -> Result<f64, String> {
    number(
        text,
        |v: &f64| v.is_finite() && *v >= 0.0,
        "a finite number ≥ 0",
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_outside_their_domain_are_refused() {
        assert_eq!(finite("1.5"), Ok(1.5));
        assert_eq!(finite("-1e3"), Ok(-1000.0));
        assert_eq!(finite("nan").unwrap_err(), "NaN is not a finite number");
        assert_eq!(finite("inf").unwrap_err(), "inf is not a finite number");
        assert_eq!(finite("x").unwrap_err(), "'x' is not a number");
        assert_eq!(positive("2.5"), Ok(2.5));
        for bad in ["0", "-1", "nan", "inf", "x", ""] {
            assert!(positive(bad).is_err(), "{bad}");
        }
        assert_eq!(
            positive("0").unwrap_err(),
            "0 is not a positive finite number"
        );
        assert_eq!(non_negative("0"), Ok(0.0));
        assert!(non_negative("-0.5").unwrap_err().contains("≥ 0"));
        assert_eq!(positive_f32("1"), Ok(1.0));
        assert!(positive_f32("1e300").is_err());
        assert!(positive_f32("NaN").is_err());
    }
}
