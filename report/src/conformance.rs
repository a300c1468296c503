//! The page's verdict (`#verdict`): the overall decision in words and
//! colour, the decision rule, and each limited figure with value ± U, its
//! limit and its decision (ISO 14253-1; `formats::conformance`), then the
//! test conditions (`crate::conditions`). The same on every page that has
//! them; it comes first, before anything else.

use std::fmt::Write;

use formats::conformance::{Decision, SignOff};

use crate::uncertainty::{plus_minus_in, unit_of};
use crate::{Page, escape};

/// Background and text colour of a decision (green, amber, red; the words
/// say it too).
fn colours(d: Decision) -> (&'static str, &'static str) {
    match d {
        Decision::Conforms => ("#d8f0d8", "#14531a"),
        Decision::Inconclusive => ("#fdf0c8", "#6b4d00"),
        Decision::DoesNotConform => ("#f8d4d4", "#7a1111"),
    }
}

/// A decision as a coloured cell's content.
fn badge(d: Decision) -> String {
    let (bg, fg) = colours(d);
    format!(
        "<span class=\"decision\" style=\"background:{bg};color:{fg};padding:1px 6px;\
         border-radius:3px;font-weight:bold\">{}</span>",
        d.words()
    )
}

/// The verdict (nothing without tolerances), then the test conditions
/// (nothing without them).
pub fn header(h: &mut Page, signoff: &SignOff) {
    verdict(h, signoff);
    crate::conditions::section(h, signoff.conditions.as_ref());
}

/// The verdict section, nothing without tolerances.
fn verdict(h: &mut Page, signoff: &SignOff) {
    let (Some(judged), Some(verdict)) = (&signoff.conformance, signoff.verdict) else {
        return;
    };
    let rule = signoff.decision_rule.as_deref();
    let (bg, fg) = colours(verdict);
    let mut html = format!(
        "<h2 id=\"verdict\">Verdict</h2>\n<p id=\"verdict-line\" style=\"background:{bg};color:{fg};\
         padding:8px 12px;font-size:1.3em;font-weight:bold;border-radius:4px\">{}</p>\n",
        escape(&format!("Verdict: {}", verdict.words()))
    );
    if let Some(rule) = rule {
        let _ = writeln!(
            html,
            "<p class=\"meta\">Decision rule: {}</p>",
            escape(rule)
        );
    }
    html.push_str(
        "<table id=\"conformance\">\n<tr><th class=\"l\">axis</th><th class=\"l\">figure</th>\
         <th>value ± U</th><th>limit</th><th class=\"l\">decision</th></tr>\n",
    );
    for j in judged {
        let unit = unit_of(&j.figure);
        let _ = writeln!(
            html,
            "<tr><td class=\"l\">{}</td><td class=\"l\">{}</td><td>{}</td><td>{}</td><td class=\"l\">{}</td></tr>",
            escape(j.axis.as_deref().unwrap_or("—")),
            escape(&j.figure),
            escape(&plus_minus_in(j.value, j.expanded, 3, unit)),
            escape(&plus_minus_in(j.limit, None, 3, unit)),
            badge(j.decision)
        );
    }
    html.push_str("</table>\n");
    h.raw(&html);
}
