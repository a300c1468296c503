//! Evaluation of linear-axis measurements (METHODS.md §1): ISO 230-2
//! positioning, VDI/DGQ 3441, straightness, flatness and angular errors, and
//! the report people read (`report.json`, CSV tables, `report.html`).
//!
//! # Conventions
//! - Input `points.csv` rows (INTERFACES.md) in millimetres; figures in
//!   micrometres (`_um`) and microradians (`_urad`).

mod error;

pub mod report;

pub use error::{EvaluateError, Result};
pub use report::Report;

/// What to evaluate and how.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Options {
    /// Sphere that carries positioning, straightness and flatness; `None`:
    /// `A`, or the first sphere name in the points when there is no `A`.
    pub sphere: Option<String>,
    /// Also compute the VDI/DGQ 3441 figures (P, Ps, U, Pa).
    pub vdi3441: bool,
}

/// Evaluate every axis, line and the flatness from `points.csv` rows given in
/// memory; errors name row `i` as line `i + 2` (as written to a points.csv).
pub fn evaluate(points: &[formats::PointRow], options: &Options) -> Result<Report> {
    let _ = (points, options);
    Err(EvaluateError::Data {
        what: "evaluate",
        message: "not implemented yet".into(),
    })
}
