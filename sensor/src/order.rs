//! Order statistics of pixel values: median, percentiles, the median
//! absolute deviation. Each reorders its scratch slice.

/// `1/Φ⁻¹(3/4)`: the MAD of a normal distribution times this is its σ.
pub(crate) const MAD_TO_SIGMA: f64 = 1.482_602_218_505_602;

/// The `q`-quantile (`0 ≤ q ≤ 1`) by the nearest rank `round(q·(n − 1))`;
/// `None` for no values.
pub(crate) fn quantile(values: &mut [f64], q: f64) -> Option<f64> {
    let last = values.len().checked_sub(1)?;
    let rank = ((q.clamp(0.0, 1.0) * last as f64).round() as usize).min(last);
    let (_, v, _) = values.select_nth_unstable_by(rank, f64::total_cmp);
    Some(*v)
}

/// The median: the middle value, or the mean of the two middle values.
pub(crate) fn median(values: &mut [f64]) -> Option<f64> {
    let n = values.len();
    if n == 0 {
        return None;
    }
    let (low, upper, _) = values.select_nth_unstable_by(n / 2, f64::total_cmp);
    let upper = *upper;
    if n % 2 == 1 {
        return Some(upper);
    }
    let lower = low.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    Some(0.5 * (lower + upper))
}

/// The robust σ `MAD_TO_SIGMA · median|x − median|` and the median; the
/// values are overwritten with the absolute deviations.
pub(crate) fn median_and_sigma(values: &mut [f64]) -> Option<(f64, f64)> {
    let centre = median(values)?;
    for v in values.iter_mut() {
        *v = (*v - centre).abs();
    }
    let mad = median(values)?;
    Some((centre, MAD_TO_SIGMA * mad))
}

/// Mean and population variance of a set of values (`None` when empty),
/// summed in order.
pub(crate) fn mean_var(values: impl Iterator<Item = f64> + Clone) -> Option<(f64, f64)> {
    let (n, sum) = values
        .clone()
        .fold((0usize, 0.0), |(n, s), v| (n + 1, s + v));
    if n == 0 {
        return None;
    }
    let mean = sum / n as f64;
    let var = values.map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64;
    Some((mean, var))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), Some(2.5));
        assert_eq!(median(&mut []), None);
    }

    #[test]
    fn quantiles_by_nearest_rank() {
        let mut v: Vec<f64> = (0..101).map(f64::from).collect();
        assert_eq!(quantile(&mut v, 0.01), Some(1.0));
        assert_eq!(quantile(&mut v, 1.0), Some(100.0));
    }

    #[test]
    fn mad_sigma_ignores_an_outlier() {
        let mut v = vec![-1.0, 0.0, 1.0, 1000.0, -1.0, 0.0, 1.0];
        let (m, s) = median_and_sigma(&mut v).unwrap();
        assert_eq!(m, 0.0);
        assert!((s - MAD_TO_SIGMA).abs() < 1e-12);
    }

    #[test]
    fn mean_and_variance() {
        let v = [1.0, 2.0, 3.0, 4.0];
        let (m, var) = mean_var(v.iter().copied()).unwrap();
        assert_eq!(m, 2.5);
        assert_eq!(var, 1.25);
    }
}
