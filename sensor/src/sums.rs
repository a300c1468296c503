//! Sums over the rows of a frame that do not depend on the thread count:
//! each row is summed on one thread, the rows' sums are added in order.

use rayon::prelude::*;

/// `Σ_y row_sums(y)` over `rows` rows, component-wise, rows added in order.
pub(crate) fn sum_rows<const K: usize>(
    rows: usize,
    row_sums: impl Fn(usize) -> [f64; K] + Sync + Send,
) -> [f64; K] {
    let per_row: Vec<[f64; K]> = (0..rows).into_par_iter().map(row_sums).collect();
    per_row.iter().fold([0.0; K], |mut acc, r| {
        for (a, v) in acc.iter_mut().zip(r) {
            *a += v;
        }
        acc
    })
}

/// Population variance from `[n, Σx, Σx²]`.
pub(crate) fn variance_of(n: f64, s1: f64, s2: f64) -> f64 {
    let n = n.max(1.0);
    (s2 / n - (s1 / n).powi(2)).max(0.0)
}
