//! Civil date-times of the images' time stamps (proleptic Gregorian
//! calendar, no time zones: camera clocks keep local civil time), through
//! `jiff`'s calendar.

use jiff::civil::DateTime;
use jiff::tz::TimeZone;
use jiff::{SignedDuration, Timestamp};
use thiserror::Error;

/// Digits of the EXIF sub-second field (0.1 ms: frames at 180 fps are 5.6 ms apart).
pub const SUBSEC_DIGITS: usize = 4;

/// A time stamp that is not a date-time `YYYY-MM-DDTHH:MM:SS[.fff]`.
#[derive(Debug, Error)]
#[error("'{text}' is not a date-time YYYY-MM-DDTHH:MM:SS[.fff]: {source}")]
pub struct DateTimeError {
    /// The text as given.
    pub text: String,
    /// What the calendar reported.
    pub source: jiff::Error,
}

/// Seconds since 1970-01-01T00:00:00 of `YYYY-MM-DDTHH:MM:SS[.fff]` (a space
/// may replace the `T`); impossible dates (31 February) are errors.
pub fn parse(text: &str) -> Result<f64, DateTimeError> {
    let err = |source| DateTimeError {
        text: text.to_string(),
        source,
    };
    let dt: DateTime = text.replacen(' ', "T", 1).parse().map_err(err)?;
    let ts = TimeZone::UTC.to_timestamp(dt).map_err(err)?;
    Ok(ts.as_duration().as_secs_f64())
}

/// EXIF date-time `YYYY:MM:DD HH:MM:SS` and sub-second digits of a time in
/// seconds since 1970 (the sub-seconds truncated to [`SUBSEC_DIGITS`]).
pub fn exif(seconds: f64) -> (String, String) {
    let scale = 10f64.powi(SUBSEC_DIGITS as i32);
    let ticks = (seconds * scale).floor() as i64;
    let whole = ticks.div_euclid(scale as i64);
    let sub = ticks.rem_euclid(scale as i64);
    let date = Timestamp::from_duration(SignedDuration::from_secs(whole))
        .map(|t| {
            TimeZone::UTC
                .to_datetime(t)
                .strftime("%Y:%m:%d %H:%M:%S")
                .to_string()
        })
        .unwrap_or_else(|_| "0000:00:00 00:00:00".to_string());
    (date, format!("{sub:0width$}", width = SUBSEC_DIGITS))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_dates() {
        assert_eq!(parse("1970-01-01T00:00:00").unwrap(), 0.0);
        // 2000-03-01 is day 11017 (after a leap day).
        assert_eq!(
            parse("2000-03-01T00:00:01").unwrap(),
            11_017.0 * 86_400.0 + 1.0
        );
        let t = parse("2025-06-02 08:00:00.25").unwrap();
        assert_eq!(
            exif(t),
            ("2025:06:02 08:00:00".to_string(), "2500".to_string())
        );
        assert_eq!(exif(t + 86_400.0 * 30.0 + 0.0055).0, "2025:07:02 08:00:00");
        assert!(parse("2025-13-01T00:00:00").is_err());
        assert!(parse("2025-02-31T00:00:00").is_err(), "31 February");
        assert!(parse("2024-02-29T00:00:00").is_ok(), "a leap day");
        assert!(parse("yesterday").is_err());
        let e = parse("2025-02-31T00:00:00").unwrap_err().to_string();
        assert!(
            e.starts_with("'2025-02-31T00:00:00' is not a date-time YYYY-MM-DDTHH:MM:SS[.fff]: "),
            "{e}"
        );
    }
}
