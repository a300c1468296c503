//! Statistics as the standards use them (ISO 230-2 §2: mean, sample standard deviation).

use crate::{GeomError, Result};

/// Arithmetic mean. Fails on an empty slice or non-finite values.
pub fn mean(values: &[f64]) -> Result<f64> {
    if values.is_empty() {
        return Err(GeomError::TooFewPoints {
            what: "mean",
            needed: 1,
            got: 0,
        });
    }
    if values.iter().any(|v| !v.is_finite()) {
        return Err(GeomError::NonFinite("mean"));
    }
    Ok(values.iter().sum::<f64>() / values.len() as f64)
}

/// Sample standard deviation with the n − 1 divisor (ISO 230-2 estimator `s`).
pub fn sample_std(values: &[f64]) -> Result<f64> {
    if values.len() < 2 {
        return Err(GeomError::TooFewPoints {
            what: "sample standard deviation",
            needed: 2,
            got: values.len(),
        });
    }
    let m = mean(values)?;
    let ss: f64 = values.iter().map(|v| (v - m) * (v - m)).sum();
    Ok((ss / (values.len() - 1) as f64).sqrt())
}

/// Root mean square of the values.
pub fn rms(values: &[f64]) -> Result<f64> {
    if values.is_empty() {
        return Err(GeomError::TooFewPoints {
            what: "rms",
            needed: 1,
            got: 0,
        });
    }
    let ss: f64 = values.iter().map(|v| v * v).sum();
    if !ss.is_finite() {
        return Err(GeomError::NonFinite("rms"));
    }
    Ok((ss / values.len() as f64).sqrt())
}

/// Range `max − min` of the values (the peak-to-valley figures of the standards).
pub fn range(values: &[f64]) -> Result<f64> {
    let (lo, hi) = min_max(values)?;
    Ok(hi - lo)
}

/// Smallest and largest value.
pub fn min_max(values: &[f64]) -> Result<(f64, f64)> {
    if values.is_empty() {
        return Err(GeomError::TooFewPoints {
            what: "range",
            needed: 1,
            got: 0,
        });
    }
    if values.iter().any(|v| !v.is_finite()) {
        return Err(GeomError::NonFinite("range"));
    }
    let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    Ok((lo, hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_std_uses_n_minus_one() {
        // 2, 4, 4, 4, 5, 5, 7, 9: population σ = 2, sample s = sqrt(32/7).
        let v = [2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0];
        assert_eq!(mean(&v).unwrap(), 5.0);
        assert!((sample_std(&v).unwrap() - (32.0f64 / 7.0).sqrt()).abs() < 1e-15);
        assert_eq!(range(&v).unwrap(), 7.0);
    }

    #[test]
    fn degenerate_inputs_are_errors() {
        assert!(mean(&[]).is_err());
        assert!(sample_std(&[1.0]).is_err());
        assert!(mean(&[1.0, f64::NAN]).is_err());
    }
}
