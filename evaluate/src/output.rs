//! Writing the report: `report.json` (docs/formats.md), CSV tables per axis
//! (`positioning_X.csv`, `straightness_X.csv`, `angular_X.csv`,
//! `flatness.csv`), `report.html` and, when asked, `report.pdf` printed from
//! it, written as one set: into a fresh
//! staging folder that then takes the place of the old report in one
//! exchange (`formats::OutputPlan::set`), so no table of an earlier report
//! stands beside a new one and a failure leaves the old report whole.

use std::path::{Path, PathBuf};

use formats::OutputPlan;

use crate::{Result, html};
use formats::evaluation::Report;

/// The files a report folder may hold (`*`: an axis name); a folder holding
/// anything else is never replaced.
pub const REPORT_FILES: &[&str] = &[
    "report.json",
    "report.html",
    "positioning_*.csv",
    "straightness_*.csv",
    "angular_*.csv",
    "flatness.csv",
    "report.pdf",
];

/// Prints a written `report.html` to PDF (`report::browser::print_pdf` with
/// the browser found): the PDF's bytes.
pub type Printer<'a> = &'a dyn Fn(&Path) -> ::report::Result<Vec<u8>>;

/// Write `report.json`, the CSV tables and `report.html` as the set `dir`
/// through `output` (where the caller declared its inputs and `--force`):
/// an existing report is replaced only with `--force`, a folder that holds
/// an input or files other than a report's never; with `print`, the page is
/// printed into the set as `report.pdf` (a failure leaves the old report).
/// Returns the paths written.
pub fn write_outputs(
    report: &Report,
    dir: &Path,
    output: &mut OutputPlan,
    print: Option<Printer<'_>>,
) -> Result<Vec<PathBuf>> {
    output.set(dir, REPORT_FILES);
    output.check()?;
    // Render first, so that a plot failure leaves nothing written.
    let page = html::render(report)?;
    let stage = output.stage(dir)?;
    let mut written = write_set(report, &page, stage.path())?;
    if let Some(print) = print {
        let pdf = stage.path().join("report.pdf");
        formats::write_atomic(&pdf, &print(&stage.path().join("report.html"))?)?;
        written.push(pdf);
    }
    stage.commit()?;
    Ok(written
        .iter()
        .filter_map(|p| p.file_name())
        .map(|name| dir.join(name))
        .collect())
}

/// Every file of the report into the folder `dir`; the paths written.
fn write_set(report: &Report, page: &str, dir: &Path) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    let json = dir.join("report.json");
    let expanded = report
        .uncertainty
        .as_ref()
        .and_then(|u| u.expanded().cloned())
        .unwrap_or_default();
    formats::uncertainty::write_with_expanded(
        &json,
        report,
        &expanded,
        &crate::uncertainty::FIGURE_KEYS,
    )?;
    written.push(json);
    written.extend(formats::evaluation::write_tables(report, dir)?);
    let path = dir.join("report.html");
    formats::write_atomic(&path, page.as_bytes())?;
    written.push(path);
    Ok(written)
}
