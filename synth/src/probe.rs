//! Generators of probe-method data with known truth (`trinocular synth
//! probe …`): measured values as an instrument would report them, from a
//! configurable truth with noise, and the truth beside them.

pub mod indexing;
pub mod rotary;
pub mod tracer;
pub mod volumetric;

/// Most rows a generator writes (ball × angle × probed point, head
/// positions, point × station readings): the data and their truth are held
/// in memory, so counts from a configuration are checked against it first.
pub const MAX_ROWS: u64 = 10_000_000;

/// Fails unless `rows ≤ MAX_ROWS`, naming the key and what multiplies into it.
pub(crate) fn check_rows(key: &str, what: &str, rows: f64) -> crate::Result<()> {
    if rows.is_finite() && rows <= MAX_ROWS as f64 {
        Ok(())
    } else {
        Err(crate::SynthError::config(format!(
            "{key}: {what} = {rows:.0} rows, more than {MAX_ROWS}"
        )))
    }
}
