//! The sign-off options of every report a machine is signed off with
//! (`evaluate` and each `probe` method): the test conditions, the limits
//! and the decision rule (`formats::conformance`), the exit status on a
//! figure proven beyond its limit, and the PDF archive copy.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::Result;
use formats::conditions::Conditions;
use formats::conformance::{Decision, Keys, Limit, Rule, SignOff, read_tolerances};

use crate::cmd::Usage;

/// Arguments shared by the reports that can be signed off.
#[derive(Debug, Clone, clap::Args)]
pub struct SignoffArgs {
    /// Test conditions (`conditions.toml`, docs/formats.md): the machine, who tested it where
    /// and when, the temperatures, shown in the report's header; `evaluate` corrects the
    /// positioning deviations to 20 °C with the machine's temperature and expansion coefficient.
    #[arg(long, value_name = "FILE")]
    pub conditions: Option<PathBuf>,
    /// Limits per figure (`tol.toml`, docs/formats.md): each figure judged by the decision rule,
    /// the verdict on the report and on stderr.
    #[arg(long, value_name = "FILE")]
    pub tolerances: Option<PathBuf>,
    /// How a figure is judged against its limit: `iso14253` (value ± U against the limit;
    /// inconclusive between) or `simple` (the value alone).
    #[arg(long, value_enum, default_value_t = DecisionRule::Iso14253, requires = "tolerances")]
    pub decision_rule: DecisionRule,
    /// Exit with status 4 when a figure does not conform (default: 0; the report is written).
    #[arg(long, requires = "tolerances")]
    pub fail_on_nonconformance: bool,
    /// Also print `report.pdf` beside `report.html` (A4, page numbers) with headless Chromium
    /// (`chromium` on the PATH, or `TRINOCULAR_CHROMIUM`).
    #[arg(long)]
    pub pdf: bool,
}

/// `--decision-rule`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum DecisionRule {
    /// ISO 14253-1: conforms when value + U ≤ limit, does not when value − U > limit.
    Iso14253,
    /// Shared risk: conforms when value ≤ limit.
    Simple,
}

impl From<DecisionRule> for Rule {
    fn from(r: DecisionRule) -> Self {
        match r {
            DecisionRule::Iso14253 => Self::Iso14253,
            DecisionRule::Simple => Self::Simple,
        }
    }
}

/// Exit status when a figure does not conform and `--fail-on-nonconformance`.
pub const NONCONFORMANCE_EXIT_STATUS: u8 = 4;

/// A run whose report was written and one of whose figures does not
/// conform, under `--fail-on-nonconformance`.
#[derive(Debug)]
pub struct DoesNotConform(pub String);

impl std::fmt::Display for DoesNotConform {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for DoesNotConform {}

impl SignoffArgs {
    /// The browser that prints the PDF, found before anything is computed
    /// so that nothing is written when it cannot be; `None` without `--pdf`.
    pub fn browser(&self) -> Result<Option<PathBuf>> {
        if !self.pdf {
            return Ok(None);
        }
        report::browser::find_browser().map(Some).ok_or_else(|| {
            Usage::error(
                "--pdf: no Chromium found to print report.pdf (install the Debian package `chromium`, \
                 or name the browser in TRINOCULAR_CHROMIUM)",
            )
        })
    }

    /// The conditions file, read and checked.
    pub fn read_conditions(&self) -> Result<Option<Conditions>> {
        Ok(self
            .conditions
            .as_deref()
            .map(Conditions::read)
            .transpose()?)
    }

    /// The tolerance file's limits, each key one of `keys`.
    pub fn read_limits(&self, keys: Keys<'_>) -> Result<Option<Vec<Limit>>> {
        Ok(self
            .tolerances
            .as_deref()
            .map(|p| read_tolerances(p, keys))
            .transpose()?)
    }

    /// The files read (inputs of the output plan).
    pub fn inputs(&self) -> impl Iterator<Item = &PathBuf> {
        self.conditions.iter().chain(self.tolerances.iter())
    }

    /// Judge `limits` (read by [`SignoffArgs::read_limits`]) on the report's
    /// `figures` with their U: fills `signoff`.
    pub fn judge(
        &self,
        signoff: &mut SignOff,
        limits: Option<&[Limit]>,
        figures: &BTreeMap<String, f64>,
        expanded: Option<&BTreeMap<String, f64>>,
    ) -> Result<()> {
        if let (Some(path), Some(limits)) = (&self.tolerances, limits) {
            signoff.judge(path, limits, figures, expanded, self.decision_rule.into())?;
        }
        Ok(())
    }

    /// After the report is written into `out`: the verdict on stderr and,
    /// with `--fail-on-nonconformance`, the error of exit status 4 when a
    /// figure does not conform.
    pub fn finish(&self, signoff: &SignOff, out: &Path) -> Result<()> {
        if let Some(line) = verdict_line(signoff) {
            eprintln!("{line}");
        }
        if self.fail_on_nonconformance && signoff.fails() {
            return Err(anyhow::Error::new(DoesNotConform(format!(
                "a figure does not conform (the report is written: {})",
                out.display()
            ))));
        }
        Ok(())
    }
}

/// Print `html` into `pdf` beside it with `browser`, atomically.
pub fn print_pdf(browser: &Path, html: &Path, pdf: &Path) -> Result<()> {
    use anyhow::Context;
    let bytes = report::browser::print_pdf(browser, html)
        .with_context(|| format!("printing {} with {}", html.display(), browser.display()))?;
    formats::write_atomic(pdf, &bytes)?;
    printed(pdf);
    Ok(())
}

/// Say that `pdf` was printed.
pub fn printed(pdf: &Path) {
    eprintln!("trinocular: printed {}", pdf.display());
}

/// The one-line verdict for stderr: the verdict, the first figure that
/// does not conform (or is inconclusive), and the counts.
fn verdict_line(signoff: &SignOff) -> Option<String> {
    let judged = signoff.conformance.as_ref()?;
    let verdict = signoff.verdict?;
    let count = |d: Decision| judged.iter().filter(|j| j.decision == d).count();
    let worst = judged
        .iter()
        .find(|j| j.decision == verdict && verdict != Decision::Conforms);
    let detail = worst.map(|j| {
        let unit = report::uncertainty::unit_of(&j.figure);
        format!(
            " ({}{} {} against {})",
            j.axis.as_ref().map(|a| format!("{a} ")).unwrap_or_default(),
            j.figure,
            report::uncertainty::plus_minus_in(j.value, j.expanded, 3, unit),
            report::uncertainty::plus_minus_in(j.limit, None, 3, unit)
        )
    });
    Some(format!(
        "trinocular: verdict: {}{}; {} conform, {} inconclusive, {} do not conform",
        verdict.words(),
        detail.unwrap_or_default(),
        count(Decision::Conforms),
        count(Decision::Inconclusive),
        count(Decision::DoesNotConform)
    ))
}
