//! Civil date-time arithmetic for the images' time stamps (proleptic
//! Gregorian calendar, no time zones), after H. Hinnant's `days_from_civil`.

/// Digits of the EXIF sub-second field (0.1 ms: frames at 180 fps are 5.6 ms apart).
pub const SUBSEC_DIGITS: usize = 4;

/// Seconds since 1970-01-01T00:00:00 of `YYYY-MM-DDTHH:MM:SS[.fff]` (a space
/// may replace the `T`).
pub fn parse(text: &str) -> Result<f64, String> {
    let err = || format!("'{text}' is not a date-time YYYY-MM-DDTHH:MM:SS[.fff]");
    let (date, time) = text.split_once(['T', ' ']).ok_or_else(err)?;
    let d: Vec<&str> = date.split('-').collect();
    let (hms, frac) = match time.split_once('.') {
        Some((a, b)) => (a, Some(b)),
        None => (time, None),
    };
    let t: Vec<&str> = hms.split(':').collect();
    if d.len() != 3 || t.len() != 3 {
        return Err(err());
    }
    let num = |s: &str| s.parse::<i64>().map_err(|_| err());
    let (y, m, day) = (num(d[0])?, num(d[1])?, num(d[2])?);
    let (h, mi, s) = (num(t[0])?, num(t[1])?, num(t[2])?);
    if !(1..=12).contains(&m)
        || !(1..=31).contains(&day)
        || !(0..24).contains(&h)
        || !(0..60).contains(&mi)
        || !(0..60).contains(&s)
    {
        return Err(err());
    }
    let fraction = match frac {
        Some(f) if !f.is_empty() && f.bytes().all(|b| b.is_ascii_digit()) => {
            format!("0.{f}").parse::<f64>().map_err(|_| err())?
        }
        Some(_) => return Err(err()),
        None => 0.0,
    };
    let days = days_from_civil(y, m, day);
    Ok((days * 86_400 + h * 3600 + mi * 60 + s) as f64 + fraction)
}

/// Days since 1970-01-01 of a civil date.
fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (m + 9) % 12;
    let doy = (153 * mp + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// Civil date (y, m, d) of a day count since 1970-01-01.
fn civil_from_days(z: i64) -> (i64, i64, i64) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    (
        if m <= 2 {
            yoe + era * 400 + 1
        } else {
            yoe + era * 400
        },
        m,
        d,
    )
}

/// EXIF date-time `YYYY:MM:DD HH:MM:SS` and sub-second digits of a time in
/// seconds since 1970 (the sub-seconds truncated to [`SUBSEC_DIGITS`]).
pub fn exif(seconds: f64) -> (String, String) {
    let scale = 10f64.powi(SUBSEC_DIGITS as i32);
    let ticks = (seconds * scale).floor() as i64;
    let whole = ticks.div_euclid(scale as i64);
    let sub = ticks.rem_euclid(scale as i64);
    let (days, secs) = (whole.div_euclid(86_400), whole.rem_euclid(86_400));
    let (y, m, d) = civil_from_days(days);
    (
        format!(
            "{y:04}:{m:02}:{d:02} {:02}:{:02}:{:02}",
            secs / 3600,
            secs / 60 % 60,
            secs % 60
        ),
        format!("{sub:0width$}", width = SUBSEC_DIGITS),
    )
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
        assert!(parse("yesterday").is_err());
    }
}
