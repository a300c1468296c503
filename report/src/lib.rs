//! Self-contained HTML report pages: one file, inline CSS and SVG, no
//! scripts, no external resources — what `trinocular evaluate` and the
//! probe methods write as `report.html`.
//!
//! - [`Page`]: the document scaffold, headings, tables, figures, notes.
//! - [`uncertainty`]: figures as value ± U and the uncertainty section
//!   (the budget table) of a report's `formats::uncertainty` object.
//! - [`plot`]: SVG plots drawn with plotters in memory, the shared chart
//!   set-up, legend and colours.
//! - `browser` (feature `browser`): opens a page in headless Chromium and
//!   checks that it logs no errors and that its plots are drawn, for tests.

#![deny(missing_docs)]

mod error;
mod page;

#[cfg(feature = "browser")]
pub mod browser;
pub mod conditions;
pub mod conformance;
pub mod plot;
pub mod uncertainty;

pub use error::{BrowserFault, ReportError, Result};
pub use page::{Page, escape, figures, num};
pub use uncertainty::{num_u, num_u_in, plus_minus, plus_minus_in};
