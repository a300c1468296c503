//! A report page in a real browser — for tests, and to print the archive
//! copy ([`print_pdf`], `evaluate --pdf`): headless Chromium (Debian
//! package `chromium`) driven over the DevTools protocol on a pipe
//! (`--remote-debugging-pipe`) opens the page, lays it out at full height,
//! takes a screenshot and collects console errors, exceptions and failed
//! loads (`Runtime.consoleAPICalled`, `Runtime.exceptionThrown`,
//! `Log.entryAdded` at level error). [`check_region`] then tells a drawn
//! plot from a blank one and a readable one from one with text under
//! [`MIN_TEXT_PX`].
//!
//! [`browser_or_skip`] finds the browser: `TRINOCULAR_CHROMIUM`, else
//! `chromium` or `chromium-browser` on the PATH. Without one the test prints
//! a notice that it is skipped, unless `TRINOCULAR_REQUIRE_BROWSER=1`, when
//! that is an error (CI sets it).
//!
//! Why a client of its own: the crates that drive Chromium
//! (`headless_chrome`, `chromiumoxide`) speak the protocol over a WebSocket,
//! with a WebSocket stack and (chromiumoxide) an async runtime; over
//! `--remote-debugging-pipe` the protocol is NUL-separated JSON on two file
//! descriptors, which serde_json and a reader thread handle here.

use std::fs::File;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::time::{Duration, Instant};

use base64::Engine;
use base64::engine::general_purpose::STANDARD;
use image::RgbaImage;
use serde_json::{Value, json};

use crate::plot::MIN_TEXT_PX;
use crate::{BrowserFault, ReportError, Result};

/// Longest wait for one browser answer.
const TIMEOUT: Duration = Duration::from_secs(60);
/// Page width (CSS px, device scale 1).
pub const PAGE_WIDTH: u32 = 1280;

fn fail(fault: BrowserFault) -> ReportError {
    ReportError::Browser(fault)
}

/// The browser to use: `TRINOCULAR_CHROMIUM` (when it names a file),
/// else `chromium` or `chromium-browser` on the PATH.
pub fn find_browser() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("TRINOCULAR_CHROMIUM") {
        return Some(PathBuf::from(p)).filter(|p| p.is_file());
    }
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .flat_map(|d| ["chromium", "chromium-browser"].map(|n| d.join(n)))
        .find(|p| p.is_file())
}

/// `Ok(Some(browser))`; `Ok(None)` after a notice on stderr naming `test`
/// as SKIPPED when there is no browser; an error when there is none and
/// `TRINOCULAR_REQUIRE_BROWSER=1`.
pub fn browser_or_skip(test: &str) -> Result<Option<PathBuf>> {
    match find_browser() {
        Some(b) => Ok(Some(b)),
        None if std::env::var("TRINOCULAR_REQUIRE_BROWSER").as_deref() == Ok("1") => {
            Err(fail(BrowserFault::Required))
        }
        None => {
            // Straight to stderr, past the test harness's capture, so that the skip is seen.
            let _ = writeln!(
                std::io::stderr(),
                "NOTICE: {test}: SKIPPED, chromium not found on the PATH \
                 (install the Debian package `chromium`; TRINOCULAR_REQUIRE_BROWSER=1 makes this an error)"
            );
            Ok(None)
        }
    }
}

/// A headless Chromium driven over `--remote-debugging-pipe` (fd 3 in, fd 4
/// out, messages separated by NUL), set up through two FIFOs.
struct Browser {
    child: Child,
    to: File,
    from: Receiver<Value>,
    next_id: u64,
    session: Option<String>,
    /// Every event received so far.
    events: Vec<Value>,
    stderr: PathBuf,
    _dir: tempfile::TempDir,
}

impl Browser {
    fn launch(browser: &Path) -> Result<Browser> {
        let io = |e: std::io::Error| {
            fail(BrowserFault::Start {
                browser: browser.to_path_buf(),
                reason: e.to_string(),
            })
        };
        let dir = tempfile::tempdir().map_err(io)?;
        let (fifo_in, fifo_out) = (dir.path().join("in"), dir.path().join("out"));
        for f in [&fifo_in, &fifo_out] {
            if !Command::new("mkfifo")
                .arg(f)
                .status()
                .map_err(io)?
                .success()
            {
                return Err(fail(BrowserFault::Fifo(f.to_path_buf())));
            }
        }
        let stderr = dir.path().join("stderr.txt");
        let child = Command::new("sh")
            .arg("-c")
            .arg(
                "exec \"$0\" --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
                 --disable-background-networking --disable-component-update --disable-sync \
                 --hide-scrollbars --user-data-dir=\"$3\" --remote-debugging-pipe 3<\"$1\" 4>\"$2\"",
            )
            .arg(browser)
            .arg(&fifo_in)
            .arg(&fifo_out)
            .arg(dir.path().join("profile"))
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(File::create(&stderr).map_err(io)?)
            .spawn()
            .map_err(io)?;
        let (tx, rx) = channel();
        std::thread::spawn(move || {
            let Ok(out) = File::open(&fifo_out) else {
                return;
            };
            let mut reader = BufReader::new(out);
            let mut buf = Vec::new();
            while reader.read_until(0, &mut buf).is_ok_and(|n| n > 0) {
                if buf.last() == Some(&0) {
                    buf.pop();
                }
                if let Ok(v) = serde_json::from_slice::<Value>(&buf)
                    && tx.send(v).is_err()
                {
                    return;
                }
                buf.clear();
            }
        });
        let to = File::options().write(true).open(&fifo_in).map_err(io)?;
        Ok(Browser {
            child,
            to,
            from: rx,
            next_id: 0,
            session: None,
            events: Vec::new(),
            stderr,
            _dir: dir,
        })
    }

    fn stderr_tail(&self) -> String {
        let text = std::fs::read_to_string(&self.stderr).unwrap_or_default();
        let lines: Vec<&str> = text.lines().collect();
        lines[lines.len().saturating_sub(15)..].join("\n")
    }

    fn send(&mut self, msg: &Value) -> Result<()> {
        let mut bytes =
            serde_json::to_vec(msg).map_err(|e| fail(BrowserFault::Encode(e.to_string())))?;
        bytes.push(0);
        self.to
            .write_all(&bytes)
            .and_then(|()| self.to.flush())
            .map_err(|e| fail(BrowserFault::Write(e.to_string())))
    }

    /// Send a command (to the page session once attached) and wait for its result.
    fn call(&mut self, method: &str, params: Value) -> Result<Value> {
        self.next_id += 1;
        let id = self.next_id;
        let mut msg = json!({"id": id, "method": method, "params": params});
        if let Some(s) = &self.session {
            msg["sessionId"] = json!(s);
        }
        self.send(&msg)?;
        let deadline = Instant::now() + TIMEOUT;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.from.recv_timeout(left) {
                Ok(v) if v["id"] == json!(id) => {
                    if let Some(e) = v.get("error") {
                        return Err(fail(BrowserFault::Refused {
                            method: method.to_string(),
                            error: e.to_string(),
                        }));
                    }
                    return Ok(v["result"].clone());
                }
                Ok(v) => self.events.push(v),
                Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => {
                    return Err(fail(BrowserFault::NoAnswer {
                        method: method.to_string(),
                        stderr: self.stderr_tail(),
                    }));
                }
            }
        }
    }

    /// Wait for an event named `method`.
    fn wait_event(&mut self, method: &str) -> Result<()> {
        if self.events.iter().any(|e| e["method"] == json!(method)) {
            return Ok(());
        }
        let deadline = Instant::now() + TIMEOUT;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.from.recv_timeout(left) {
                Ok(v) => {
                    let done = v["method"] == json!(method);
                    self.events.push(v);
                    if done {
                        return Ok(());
                    }
                }
                Err(_) => {
                    return Err(fail(BrowserFault::NoEvent {
                        event: method.to_string(),
                        stderr: self.stderr_tail(),
                    }));
                }
            }
        }
    }

    /// Open `url` in a fresh page of `PAGE_WIDTH` × `height` and wait for its load event.
    fn open(&mut self, url: &str, height: u32) -> Result<()> {
        let target = self.call("Target.createTarget", json!({"url": "about:blank"}))?;
        let attached = self.call(
            "Target.attachToTarget",
            json!({"targetId": target["targetId"], "flatten": true}),
        )?;
        let session = attached["sessionId"]
            .as_str()
            .ok_or_else(|| fail(BrowserFault::NoSession))?;
        self.session = Some(session.to_string());
        for domain in ["Runtime.enable", "Log.enable", "Page.enable"] {
            self.call(domain, json!({}))?;
        }
        self.resize(height)?;
        // Only the load of `url` counts, not a late one of about:blank.
        self.events
            .retain(|e| e["method"] != json!("Page.loadEventFired"));
        self.call("Page.navigate", json!({"url": url}))?;
        self.wait_event("Page.loadEventFired")
    }

    fn resize(&mut self, height: u32) -> Result<()> {
        self.call(
            "Emulation.setDeviceMetricsOverride",
            json!({"width": PAGE_WIDTH, "height": height, "deviceScaleFactor": 1, "mobile": false}),
        )
        .map(|_| ())
    }

    /// Evaluate a JavaScript expression in the page, by value.
    fn eval(&mut self, expression: &str) -> Result<Value> {
        let r = self.call(
            "Runtime.evaluate",
            json!({"expression": expression, "returnByValue": true}),
        )?;
        Ok(r["result"]["value"].clone())
    }

    /// Screenshot of the whole viewport as RGBA.
    fn screenshot(&mut self) -> Result<RgbaImage> {
        let r = self.call("Page.captureScreenshot", json!({"format": "png"}))?;
        let data = r["data"]
            .as_str()
            .ok_or_else(|| fail(BrowserFault::NoData))?;
        let png = STANDARD
            .decode(data)
            .map_err(|e| fail(BrowserFault::NotBase64(e.to_string())))?;
        Ok(image::load_from_memory(&png)
            .map_err(|e| fail(BrowserFault::Screenshot(e.to_string())))?
            .to_rgba8())
    }

    /// Console errors, exceptions and failed loads seen so far.
    fn errors(&mut self) -> Vec<String> {
        // Let late messages arrive.
        while let Ok(v) = self.from.recv_timeout(Duration::from_millis(300)) {
            self.events.push(v);
        }
        self.events
            .iter()
            .filter_map(|e| {
                let p = &e["params"];
                match e["method"].as_str()? {
                    "Runtime.consoleAPICalled"
                        if matches!(p["type"].as_str(), Some("error" | "assert")) =>
                    {
                        Some(format!("console.{}: {}", p["type"], p["args"]))
                    }
                    "Runtime.exceptionThrown" => {
                        Some(format!("exception: {}", p["exceptionDetails"]))
                    }
                    "Log.entryAdded" if p["entry"]["level"] == json!("error") => {
                        Some(format!("log error: {}", p["entry"]))
                    }
                    _ => None,
                }
            })
            .collect()
    }

    fn close(&mut self) {
        self.session = None;
        self.next_id += 1;
        let msg = json!({"id": self.next_id, "method": "Browser.close", "params": {}});
        let _ = self.send(&msg);
        let deadline = Instant::now() + Duration::from_secs(10);
        while Instant::now() < deadline {
            if matches!(self.child.try_wait(), Ok(Some(_))) {
                return;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for Browser {
    /// A browser left running (a failed check) is stopped: only the process started here.
    fn drop(&mut self) {
        if matches!(self.child.try_wait(), Ok(None)) {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// A plot's box on the page (CSS px = screenshot px).
#[derive(Debug, Clone, PartialEq)]
pub struct PlotBox {
    /// The `id` of its `figure.plot`.
    pub id: String,
    /// Left edge.
    pub x: u32,
    /// Top edge.
    pub y: u32,
    /// Width of the SVG.
    pub w: u32,
    /// Height of the SVG.
    pub h: u32,
    /// The smallest computed font size of its texts with content (px;
    /// infinite without any).
    pub smallest_text_px: f64,
}

/// A page as the browser showed it.
#[derive(Debug)]
pub struct Rendered {
    /// Every `figure.plot` in document order.
    pub plots: Vec<PlotBox>,
    /// Scroll width of the page (CSS px).
    pub width: u32,
    /// The whole page, laid out at its full height.
    pub screenshot: RgbaImage,
    /// Console errors, exceptions and failed loads.
    pub errors: Vec<String>,
}

const LAYOUT: &str = "JSON.stringify({height: document.documentElement.scrollHeight, \
    width: document.documentElement.scrollWidth, \
    plots: Array.from(document.querySelectorAll('figure.plot')).map(f => { \
      const s = f.querySelector('svg'); const r = s ? s.getBoundingClientRect() : {left:0,top:0,width:0,height:0}; \
      const sizes = s ? Array.from(s.querySelectorAll('text')).filter(t => t.textContent.trim() !== '') \
        .map(t => parseFloat(getComputedStyle(t).fontSize)) : []; \
      return {id: f.id, x: r.left + window.scrollX, y: r.top + window.scrollY, w: r.width, h: r.height, \
        text: sizes.length ? Math.min(...sizes) : null}; })})";

fn layout(b: &mut Browser) -> Result<Value> {
    let text = b.eval(LAYOUT)?;
    let text = text.as_str().ok_or_else(|| fail(BrowserFault::NoLayout))?;
    serde_json::from_str(text).map_err(|e| fail(BrowserFault::Layout(e.to_string())))
}

fn px(v: &Value) -> u32 {
    v.as_f64().unwrap_or(0.0).round().max(0.0) as u32
}

/// Open the HTML file `page` in `browser`, lay it out at its full height
/// (at most 16000 px) and return what was shown.
pub fn render(browser: &Path, page: &Path) -> Result<Rendered> {
    let url = file_url(page)?;
    let mut b = Browser::launch(browser)?;
    b.open(&url, 900)?;
    let first = layout(&mut b)?;
    let height = first["height"].as_u64().unwrap_or(900).clamp(100, 16000) as u32;
    b.resize(height)?;
    let shown = layout(&mut b)?;
    let screenshot = b.screenshot()?;
    let errors = b.errors();
    b.close();
    let plots = shown["plots"]
        .as_array()
        .map(|a| {
            a.iter()
                .map(|p| PlotBox {
                    id: p["id"].as_str().unwrap_or_default().to_string(),
                    x: px(&p["x"]),
                    y: px(&p["y"]),
                    w: px(&p["w"]),
                    h: px(&p["h"]),
                    smallest_text_px: p["text"].as_f64().unwrap_or(f64::INFINITY),
                })
                .collect()
        })
        .unwrap_or_default();
    Ok(Rendered {
        plots,
        width: px(&shown["width"]),
        screenshot,
        errors,
    })
}

/// The `file://` URL of `page`: its absolute path, each byte outside
/// RFC 3986's unreserved set and `/` percent-encoded.
fn file_url(page: &Path) -> Result<String> {
    let absolute = std::fs::canonicalize(page).map_err(|e| {
        fail(BrowserFault::Start {
            browser: page.to_path_buf(),
            reason: format!("the page cannot be opened: {e}"),
        })
    })?;
    let mut url = String::from("file://");
    for b in absolute.as_os_str().as_encoded_bytes() {
        match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'.' | b'_' | b'~' | b'/' => {
                url.push(char::from(*b));
            }
            _ => url.push_str(&format!("%{b:02X}")),
        }
    }
    Ok(url)
}

/// A4 in inches, as `Page.printToPDF` takes it.
const A4_IN: (f64, f64) = (8.27, 11.69);

/// The page footer of a printed report: "page n of m" (Chromium fills the
/// `pageNumber` and `totalPages` spans).
const FOOTER: &str = "<div style=\"font: 8px sans-serif; width: 100%; text-align: center;\">page \
     <span class=\"pageNumber\"></span> of <span class=\"totalPages\"></span></div>";

/// The HTML file `page` printed to PDF by `browser` (`Page.printToPDF`):
/// A4, backgrounds printed (the verdict's colours), page numbers in the
/// footer, scaled so that the page's width fits. The PDF's bytes.
pub fn print_pdf(browser: &Path, page: &Path) -> Result<Vec<u8>> {
    let url = file_url(page)?;
    let mut b = Browser::launch(browser)?;
    b.open(&url, 900)?;
    let errors = b.errors();
    if !errors.is_empty() {
        b.close();
        return Err(fail(BrowserFault::Refused {
            method: format!("loading {url}"),
            error: errors.join("; "),
        }));
    }
    let printed = b.call(
        "Page.printToPDF",
        json!({
            "paperWidth": A4_IN.0,
            "paperHeight": A4_IN.1,
            "marginTop": 0.4,
            "marginBottom": 0.5,
            "marginLeft": 0.4,
            "marginRight": 0.4,
            "scale": 0.8,
            "printBackground": true,
            "displayHeaderFooter": true,
            "headerTemplate": "<span></span>",
            "footerTemplate": FOOTER,
        }),
    );
    b.close();
    let data = printed?;
    let data = data["data"]
        .as_str()
        .ok_or_else(|| fail(BrowserFault::NoData))?;
    STANDARD
        .decode(data)
        .map_err(|e| fail(BrowserFault::NotBase64(e.to_string())))
}

/// Near `c` within `tol` per channel.
fn near(p: &image::Rgba<u8>, c: [u8; 3], tol: i32) -> bool {
    (0..3).all(|i| (i32::from(p[i]) - i32::from(c[i])).abs() <= tol)
}

/// The region of `img` under `b` is a drawn, readable plot: its texts are
/// at least [`MIN_TEXT_PX`], ≥ 3 % of its pixels differ from white, ≥ 12
/// distinct colours (quantised), and each of `colours` covers ≥ 40 pixels.
/// The error says which test failed.
pub fn check_region(
    img: &RgbaImage,
    b: &PlotBox,
    colours: &[[u8; 3]],
) -> std::result::Result<(), String> {
    if b.smallest_text_px < MIN_TEXT_PX {
        return Err(format!(
            "{}: text of {:.2} px, under the {MIN_TEXT_PX} px readable at 100 % zoom",
            b.id, b.smallest_text_px
        ));
    }
    if b.x + b.w > img.width() || b.y + b.h > img.height() || b.w < 100 || b.h < 100 {
        return Err(format!(
            "{}: box {b:?} outside a {}×{} screenshot",
            b.id,
            img.width(),
            img.height()
        ));
    }
    let mut drawn = 0usize;
    let mut palette = std::collections::HashSet::new();
    let mut hits = vec![0usize; colours.len()];
    for y in b.y..b.y + b.h {
        for x in b.x..b.x + b.w {
            let p = img.get_pixel(x, y);
            if !near(p, [255, 255, 255], 8) {
                drawn += 1;
            }
            palette.insert((p[0] >> 3, p[1] >> 3, p[2] >> 3));
            for (k, c) in colours.iter().enumerate() {
                if near(p, *c, 24) {
                    hits[k] += 1;
                }
            }
        }
    }
    let area = (b.w * b.h) as usize;
    if drawn * 100 < 3 * area {
        return Err(format!(
            "{}: only {drawn} of {area} pixels drawn: blank",
            b.id
        ));
    }
    if palette.len() < 12 {
        return Err(format!("{}: only {} colours", b.id, palette.len()));
    }
    for (c, n) in colours.iter().zip(hits) {
        if n < 40 {
            return Err(format!("{}: series colour {c:?} covers {n} pixels", b.id));
        }
    }
    Ok(())
}

/// The colour triple of a plot colour, for [`check_region`].
pub fn rgb(c: crate::plot::RGBColor) -> [u8; 3] {
    [c.0, c.1, c.2]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The harness can fail: a page with a console error and a missing image
    /// is caught, and a blank region is rejected.
    #[test]
    fn catches_console_errors_and_blank_plots() {
        let browser = match browser_or_skip("report::browser harness test") {
            Ok(Some(b)) => b,
            Ok(None) => return,
            Err(e) => panic!("{e}"),
        };
        let dir = tempfile::tempdir().expect("temp dir");
        let page = dir.path().join("bad.html");
        std::fs::write(
            &page,
            "<!DOCTYPE html><html><body><figure class=\"plot\" id=\"plot-blank\">\
             <svg width=\"400\" height=\"300\"><rect width=\"400\" height=\"300\" fill=\"white\"/></svg></figure>\
             <img src=\"missing.png\"><script>console.error('broken')</script></body></html>",
        )
        .expect("write page");
        let shown = render(&browser, &page).expect("render");
        assert!(
            shown.errors.iter().any(|e| e.contains("broken")),
            "console.error missed: {:#?}",
            shown.errors
        );
        assert!(
            shown.errors.iter().any(|e| e.contains("missing.png")),
            "failed load missed: {:#?}",
            shown.errors
        );
        assert_eq!(shown.plots.len(), 1);
        assert!(
            check_region(&shown.screenshot, &shown.plots[0], &[]).is_err(),
            "a blank plot passed"
        );
    }

    /// A plot whose smallest text is under 11 px is caught, one of 11 px is not.
    #[test]
    fn catches_text_too_small_to_read() {
        let browser = match browser_or_skip("report::browser text size test") {
            Ok(Some(b)) => b,
            Ok(None) => return,
            Err(e) => panic!("{e}"),
        };
        let dir = tempfile::tempdir().expect("temp dir");
        let page = dir.path().join("small.html");
        let figure = |id: &str, px: f64| {
            format!(
                "<figure class=\"plot\" id=\"{id}\"><svg width=\"400\" height=\"300\">\
                 <text x=\"10\" y=\"20\" font-size=\"{px}\">label</text>\
                 <text x=\"10\" y=\"60\" font-size=\"6\"> </text></svg></figure>"
            )
        };
        std::fs::write(
            &page,
            format!(
                "<!DOCTYPE html><html><body>{}{}</body></html>",
                figure("small", 9.68),
                figure("readable", 11.0)
            ),
        )
        .expect("write page");
        let shown = render(&browser, &page).expect("render");
        assert!((shown.plots[0].smallest_text_px - 9.68).abs() < 0.01);
        let err = check_region(&shown.screenshot, &shown.plots[0], &[]).unwrap_err();
        assert!(err.contains("9.68 px"), "{err}");
        assert_eq!(shown.plots[1].smallest_text_px, 11.0);
        let err = check_region(&shown.screenshot, &shown.plots[1], &[]).unwrap_err();
        assert!(err.contains("blank"), "{err}");
    }
}
