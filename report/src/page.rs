//! The page scaffold: `<!DOCTYPE html>`, the one style sheet, headings,
//! tables, figures and notes, appended in reading order.

use std::fmt::Write;

/// Escape text for HTML content and attribute values.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// A figure to 3 decimals, or an em dash when absent.
pub fn num(v: Option<f64>) -> String {
    v.map_or_else(|| "—".into(), |v| format!("{v:.3}"))
}

/// The one style sheet; its last line is for the printed page (report.pdf):
/// a heading stays with the block after it, a plot or a table row on one page
/// (CSS Fragmentation §3, break-after / break-inside).
const STYLE: &str = "
body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,'DejaVu Sans',sans-serif;margin:0;background:#f5f6f8;color:#1d2127}
main{max-width:960px;margin:0 auto;padding:16px 24px 48px}
h1{font-size:26px;margin:18px 0 4px}h2{font-size:21px;margin:34px 0 8px;border-bottom:2px solid #d0d5dd;padding-bottom:4px}
h3{font-size:17px;margin:22px 0 8px}p.meta{color:#555;margin:0 0 12px}
table{border-collapse:collapse;margin:8px 0 14px;background:#fff;font-size:13.5px}
th,td{border:1px solid #d0d5dd;padding:3px 8px;text-align:right}th{background:#eef1f5}
td.l,th.l{text-align:left}
figure.plot{margin:10px 0 16px;background:#fff;border:1px solid #d0d5dd;padding:6px;width:min-content}
figure.plot svg{display:block}figcaption{font-size:13px;color:#444;padding:4px 2px 0}
ul.notes{font-size:13px;color:#444}.warn{color:#8a4b00}
h1,h2,h3,p.meta{break-after:avoid;page-break-after:avoid}figure.plot,tr{break-inside:avoid;page-break-inside:avoid}
";

/// An HTML page being written; [`Page::finish`] closes it.
///
/// Text arguments are escaped; arguments named `html` are inserted as they
/// are (the caller escapes what it interpolates).
#[derive(Debug, Clone)]
pub struct Page {
    html: String,
}

impl Page {
    /// A page with `title` (browser tab) and an `<h1>` heading.
    pub fn new(title: &str, heading: &str) -> Page {
        let mut html = String::new();
        let _ = write!(
            html,
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
             <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
             <title>{}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<main>\n<h1>{}</h1>\n",
            escape(title),
            escape(heading)
        );
        Page { html }
    }

    /// Markup inserted as it is.
    pub fn raw(&mut self, html: &str) -> &mut Self {
        self.html.push_str(html);
        self
    }

    /// A grey line under a heading (`html`, e.g. with `<b>`).
    pub fn meta(&mut self, html: &str) -> &mut Self {
        let _ = writeln!(self.html, "<p class=\"meta\">{html}</p>");
        self
    }

    /// A paragraph of plain text.
    pub fn paragraph(&mut self, text: &str) -> &mut Self {
        let _ = writeln!(self.html, "<p>{}</p>", escape(text));
        self
    }

    /// A section heading with an anchor `id`.
    pub fn h2(&mut self, id: &str, text: &str) -> &mut Self {
        let _ = writeln!(self.html, "<h2 id=\"{}\">{}</h2>", escape(id), escape(text));
        self
    }

    /// A sub-section heading.
    pub fn h3(&mut self, text: &str) -> &mut Self {
        let _ = writeln!(self.html, "<h3>{}</h3>", escape(text));
        self
    }

    /// A table: `header` and `rows` are plain text; the first column is
    /// left-aligned (labels), the others right-aligned (figures).
    pub fn table<S: AsRef<str>>(
        &mut self,
        id: Option<&str>,
        header: &[&str],
        rows: &[Vec<S>],
    ) -> &mut Self {
        match id {
            Some(id) => {
                let _ = writeln!(self.html, "<table id=\"{}\">", escape(id));
            }
            None => self.html.push_str("<table>\n"),
        }
        self.html.push_str("<tr>");
        for (k, h) in header.iter().enumerate() {
            let class = if k == 0 { " class=\"l\"" } else { "" };
            let _ = write!(self.html, "<th{class}>{}</th>", escape(h));
        }
        self.html.push_str("</tr>\n");
        for row in rows {
            self.html.push_str("<tr>");
            for (k, cell) in row.iter().enumerate() {
                let class = if k == 0 { " class=\"l\"" } else { "" };
                let _ = write!(self.html, "<td{class}>{}</td>", escape(cell.as_ref()));
            }
            self.html.push_str("</tr>\n");
        }
        self.html.push_str("</table>\n");
        self
    }

    /// A plot (`svg` markup from [`crate::plot`]) in a figure with an `id`
    /// (the browser test finds plots by `figure.plot` and this id) and a caption.
    pub fn figure(&mut self, id: &str, svg: &str, caption: &str) -> &mut Self {
        let _ = write!(
            self.html,
            "{FIGURE}{}\">\n{svg}\n<figcaption>{}</figcaption>\n</figure>\n",
            escape(id),
            escape(caption)
        );
        self
    }

    /// A bulleted list of plain-text notes under a heading; `warn` colours it.
    pub fn notes(&mut self, heading: &str, items: &[String], warn: bool) -> &mut Self {
        if items.is_empty() {
            return self;
        }
        let class = if warn { "notes warn" } else { "notes" };
        let _ = writeln!(
            self.html,
            "<h2>{}</h2>\n<ul class=\"{class}\">",
            escape(heading)
        );
        for item in items {
            let _ = writeln!(self.html, "<li>{}</li>", escape(item));
        }
        self.html.push_str("</ul>\n");
        self
    }

    /// Close the page and return its markup.
    pub fn finish(mut self) -> String {
        self.html.push_str("</main>\n</body>\n</html>\n");
        self.html
    }
}

/// How [`Page::figure`] opens a figure, up to its id.
const FIGURE: &str = "<figure class=\"plot\" id=\"";

/// The plots of a page written by [`Page::figure`]: each figure's id (as
/// escaped) and its `<svg>…</svg>`, in page order (for checks of the plots
/// as a reader sees them).
pub fn figures(html: &str) -> Vec<(String, String)> {
    html.split(FIGURE)
        .skip(1)
        .filter_map(|f| {
            let id = &f[..f.find('"')?];
            let svg = &f[f.find("<svg")?..f.find("</svg>")? + "</svg>".len()];
            Some((id.to_string(), svg.to_string()))
        })
        .collect()
}

/// `write!` appends markup as it is (like [`Page::raw`]).
impl Write for Page {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        self.html.push_str(s);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The printed page (`report.pdf`; CSS Fragmentation §3) keeps a
    /// heading, and the grey line under it, with the block that follows,
    /// and a plot or a table row on one page.
    #[test]
    fn printed_headings_stay_with_their_block() {
        let html = Page::new("t", "h").finish();
        for rule in [
            "h1,h2,h3,p.meta{break-after:avoid;page-break-after:avoid}",
            "figure.plot,tr{break-inside:avoid;page-break-inside:avoid}",
        ] {
            assert!(html.contains(rule), "{rule}");
        }
    }

    #[test]
    fn escapes_markup() {
        assert_eq!(escape("a<b & \"c\""), "a&lt;b &amp; &quot;c&quot;");
    }

    #[test]
    fn page_is_closed_and_escaped() {
        let mut p = Page::new("t<", "H&");
        p.table(Some("x"), &["a", "b"], &[vec!["<1>", "2"]]);
        let html = p.finish();
        assert!(html.starts_with("<!DOCTYPE html>"));
        assert!(html.contains("<title>t&lt;</title>") && html.contains("<h1>H&amp;</h1>"));
        assert!(html.contains("<td class=\"l\">&lt;1&gt;</td><td>2</td>"));
        assert!(html.trim_end().ends_with("</html>"));
    }

    #[test]
    fn figures_are_read_back() {
        let mut p = Page::new("t", "h");
        p.figure("plot-a", "<svg width=\"1\"><text>1</text></svg>", "a")
            .figure("plot-b", "<svg/></svg>", "b");
        let f = figures(&p.finish());
        assert_eq!(
            f,
            vec![
                (
                    "plot-a".into(),
                    "<svg width=\"1\"><text>1</text></svg>".into()
                ),
                ("plot-b".into(), "<svg/></svg>".into())
            ]
        );
    }
}
