//! `report.html` in a real browser: headless Chromium (Debian package
//! `chromium`) opens a report written from a realistic campaign, driven over
//! the DevTools protocol on a pipe (`--remote-debugging-pipe`). The test
//! checks that
//! - the page logs no console errors, no uncaught exceptions and no failed
//!   loads (`Runtime.consoleAPICalled`, `Runtime.exceptionThrown`,
//!   `Log.entryAdded` at level error);
//! - every plot the report should have is laid out at its full size, and in a
//!   full-page screenshot (PNG, decoded with `image`) its region is not blank:
//!   enough drawn pixels, enough distinct colours, and the series colours of
//!   that kind of plot.
//!
//! The harness proves it can fail: a page with a console error and a missing
//! image is caught, and a blank region is rejected.
//!
//! Without `chromium` on the PATH (or `TRINOCULAR_CHROMIUM`) the test prints a
//! notice and passes, unless `TRINOCULAR_REQUIRE_BROWSER=1`, when it fails.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::fs::File;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::time::{Duration, Instant};

use image::RgbaImage;
use serde_json::{Value, json};

/// Longest wait for one browser answer.
const TIMEOUT: Duration = Duration::from_secs(60);
/// Page width (CSS px, device scale 1).
const WIDTH: u32 = 1280;

/// The browser to use: `TRINOCULAR_CHROMIUM`, else `chromium` or
/// `chromium-browser` on the PATH.
fn find_browser() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("TRINOCULAR_CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .flat_map(|d| ["chromium", "chromium-browser"].map(|n| d.join(n)))
        .find(|p| p.is_file())
}

/// `Some(browser)`, or `None` after a notice when the browser may be skipped.
fn browser_or_skip() -> Option<PathBuf> {
    match find_browser() {
        Some(b) => Some(b),
        None if std::env::var("TRINOCULAR_REQUIRE_BROWSER").as_deref() == Ok("1") => {
            panic!(
                "TRINOCULAR_REQUIRE_BROWSER=1 but no chromium on the PATH (apt-get install chromium)"
            )
        }
        None => {
            // Straight to stderr, past the test harness's capture, so that the skip is seen.
            let _ = writeln!(
                std::io::stderr(),
                "NOTICE: chromium not found on the PATH: the browser test of report.html is SKIPPED \
                 (install the Debian package `chromium`; set TRINOCULAR_REQUIRE_BROWSER=1 to make this an error)"
            );
            None
        }
    }
}

/// Standard base64 (with padding) to bytes.
fn base64(text: &str) -> Vec<u8> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => panic!("not base64: {c}"),
    };
    let clean: Vec<u8> = text
        .bytes()
        .filter(|c| !c.is_ascii_whitespace() && *c != b'=')
        .collect();
    let mut out = Vec::with_capacity(clean.len() * 3 / 4);
    for chunk in clean.chunks(4) {
        let v: Vec<u32> = chunk.iter().map(|&c| u32::from(value(c))).collect();
        let n = v
            .iter()
            .enumerate()
            .fold(0u32, |n, (i, x)| n | (x << (18 - 6 * i)));
        out.extend(n.to_be_bytes()[1..chunk.len()].iter());
    }
    out
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
    fn launch(browser: &Path) -> Browser {
        let dir = tempfile::tempdir().unwrap();
        let (fifo_in, fifo_out) = (dir.path().join("in"), dir.path().join("out"));
        for f in [&fifo_in, &fifo_out] {
            assert!(Command::new("mkfifo").arg(f).status().unwrap().success());
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
            .stderr(File::create(&stderr).unwrap())
            .spawn()
            .unwrap();
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
        let to = File::options().write(true).open(&fifo_in).unwrap();
        Browser {
            child,
            to,
            from: rx,
            next_id: 0,
            session: None,
            events: Vec::new(),
            stderr,
            _dir: dir,
        }
    }

    fn stderr_tail(&self) -> String {
        let text = std::fs::read_to_string(&self.stderr).unwrap_or_default();
        let lines: Vec<&str> = text.lines().collect();
        lines[lines.len().saturating_sub(15)..].join("\n")
    }

    /// Send a command (to the page session once attached) and wait for its result.
    fn call(&mut self, method: &str, params: Value) -> Value {
        self.next_id += 1;
        let id = self.next_id;
        let mut msg = json!({"id": id, "method": method, "params": params});
        if let Some(s) = &self.session {
            msg["sessionId"] = json!(s);
        }
        let mut bytes = serde_json::to_vec(&msg).unwrap();
        bytes.push(0);
        self.to.write_all(&bytes).unwrap();
        self.to.flush().unwrap();
        let deadline = Instant::now() + TIMEOUT;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.from.recv_timeout(left) {
                Ok(v) if v["id"] == json!(id) => {
                    assert!(v.get("error").is_none(), "{method} failed: {}", v["error"]);
                    return v["result"].clone();
                }
                Ok(v) => self.events.push(v),
                Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => {
                    panic!(
                        "no answer to {method} from the browser; its stderr:\n{}",
                        self.stderr_tail()
                    )
                }
            }
        }
    }

    /// Wait for an event named `method`.
    fn wait_event(&mut self, method: &str) {
        if self.events.iter().any(|e| e["method"] == json!(method)) {
            return;
        }
        let deadline = Instant::now() + TIMEOUT;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.from.recv_timeout(left) {
                Ok(v) => {
                    let done = v["method"] == json!(method);
                    self.events.push(v);
                    if done {
                        return;
                    }
                }
                Err(_) => panic!(
                    "no {method} from the browser; its stderr:\n{}",
                    self.stderr_tail()
                ),
            }
        }
    }

    /// Open `url` in a fresh page of `WIDTH` × `height` and wait for its load event.
    fn open(&mut self, url: &str, height: u32) {
        let target = self.call("Target.createTarget", json!({"url": "about:blank"}));
        let attached = self.call(
            "Target.attachToTarget",
            json!({"targetId": target["targetId"], "flatten": true}),
        );
        self.session = Some(attached["sessionId"].as_str().unwrap().to_string());
        for domain in ["Runtime.enable", "Log.enable", "Page.enable"] {
            self.call(domain, json!({}));
        }
        self.resize(height);
        // Only the load of `url` counts, not a late one of about:blank.
        self.events
            .retain(|e| e["method"] != json!("Page.loadEventFired"));
        self.call("Page.navigate", json!({"url": url}));
        self.wait_event("Page.loadEventFired");
    }

    fn resize(&mut self, height: u32) {
        self.call(
            "Emulation.setDeviceMetricsOverride",
            json!({"width": WIDTH, "height": height, "deviceScaleFactor": 1, "mobile": false}),
        );
    }

    /// Evaluate a JavaScript expression in the page, by value.
    fn eval(&mut self, expression: &str) -> Value {
        let r = self.call(
            "Runtime.evaluate",
            json!({"expression": expression, "returnByValue": true}),
        );
        r["result"]["value"].clone()
    }

    /// Screenshot of the whole viewport as RGBA.
    fn screenshot(&mut self) -> RgbaImage {
        let r = self.call("Page.captureScreenshot", json!({"format": "png"}));
        let png = base64(r["data"].as_str().unwrap());
        image::load_from_memory(&png).unwrap().to_rgba8()
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
        let mut bytes = serde_json::to_vec(&msg).unwrap();
        bytes.push(0);
        let _ = self.to.write_all(&bytes);
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
    /// A browser left running by a failed test is stopped (only the process this test started).
    fn drop(&mut self) {
        if matches!(self.child.try_wait(), Ok(None)) {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// A plot's box on the page (CSS px = screenshot px).
#[derive(Debug)]
struct PlotBox {
    id: String,
    x: u32,
    y: u32,
    w: u32,
    h: u32,
}

/// Near `c` within `tol` per channel.
fn near(p: &image::Rgba<u8>, c: [u8; 3], tol: i32) -> bool {
    (0..3).all(|i| (i32::from(p[i]) - i32::from(c[i])).abs() <= tol)
}

/// The region of `img` under `b` is a drawn plot: ≥ 3 % of its pixels differ
/// from white, ≥ 12 distinct colours (quantised), and each of `colours`
/// covers ≥ 40 pixels.
fn check_region(img: &RgbaImage, b: &PlotBox, colours: &[[u8; 3]]) -> Result<(), String> {
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

/// The series colours a plot of this id must show.
fn colours_of(id: &str) -> Vec<[u8; 3]> {
    let rgb = |c: evaluate::plot::RGBColor| [c.0, c.1, c.2];
    use evaluate::plot::{DOWN, MEAN, RPY, UP, ZONE};
    if id.ends_with("positioning") {
        vec![rgb(UP), rgb(DOWN)]
    } else if id.contains("straightness") {
        vec![rgb(MEAN), rgb(ZONE), rgb(UP)]
    } else if id.ends_with("angular") {
        RPY.iter().map(|c| rgb(*c)).collect()
    } else {
        // The flatness map: both ends of the diverging scale.
        vec![
            rgb(evaluate::plot::diverging(-1.0)),
            rgb(evaluate::plot::diverging(1.0)),
        ]
    }
}

const LAYOUT: &str = "JSON.stringify({height: document.documentElement.scrollHeight, \
    width: document.documentElement.scrollWidth, \
    plots: Array.from(document.querySelectorAll('figure.plot')).map(f => { \
      const s = f.querySelector('svg'); const r = s ? s.getBoundingClientRect() : {left:0,top:0,width:0,height:0}; \
      return {id: f.id, x: r.left + window.scrollX, y: r.top + window.scrollY, w: r.width, h: r.height}; })})";

/// Open `url`, lay it out at full height; (layout, screenshot, errors).
fn render(browser: &Path, url: &str) -> (Value, RgbaImage, Vec<String>) {
    let mut b = Browser::launch(browser);
    b.open(url, 900);
    let layout: Value = serde_json::from_str(b.eval(LAYOUT).as_str().unwrap()).unwrap();
    let height = layout["height"].as_u64().unwrap().clamp(100, 16000) as u32;
    b.resize(height);
    let layout: Value = serde_json::from_str(b.eval(LAYOUT).as_str().unwrap()).unwrap();
    let img = b.screenshot();
    let errors = b.errors();
    b.close();
    (layout, img, errors)
}

fn boxes(layout: &Value) -> Vec<PlotBox> {
    layout["plots"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| PlotBox {
            id: p["id"].as_str().unwrap().to_string(),
            x: p["x"].as_f64().unwrap().round() as u32,
            y: p["y"].as_f64().unwrap().round() as u32,
            w: p["w"].as_f64().unwrap().round() as u32,
            h: p["h"].as_f64().unwrap().round() as u32,
        })
        .collect()
}

#[test]
fn report_html_renders_in_chromium() {
    let Some(browser) = browser_or_skip() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let rows = common::rows(&common::campaign());
    let report = evaluate::evaluate(
        &rows,
        &evaluate::Options {
            vdi3441: true,
            ..Default::default()
        },
    )
    .unwrap();
    evaluate::write_outputs(&report, dir.path()).unwrap();
    let url = format!("file://{}", dir.path().join("report.html").display());
    let (layout, img, errors) = render(&browser, &url);
    assert!(errors.is_empty(), "console errors: {errors:#?}");
    let plots = boxes(&layout);
    let ids: Vec<&str> = plots.iter().map(|p| p.id.as_str()).collect();
    let mut expected = Vec::new();
    for (axis, perp) in [("X", ["Y", "Z"]), ("Y", ["X", "Z"])] {
        expected.push(format!("plot-{axis}-positioning"));
        expected.extend(perp.map(|d| format!("plot-{axis}-straightness-{d}")));
        expected.push(format!("plot-{axis}-angular"));
    }
    expected.push("plot-flatness".into());
    assert_eq!(ids, expected, "plots on the page");
    assert!(
        layout["width"].as_u64().unwrap() <= u64::from(WIDTH),
        "page wider than the window: {layout}"
    );
    for p in &plots {
        let full = if p.id == "plot-flatness" {
            evaluate::plot::MAP_HEIGHT
        } else {
            evaluate::plot::HEIGHT
        };
        assert_eq!(
            (p.w, p.h),
            (evaluate::plot::WIDTH, full),
            "{} laid out at {}×{}",
            p.id,
            p.w,
            p.h
        );
        check_region(&img, p, &colours_of(&p.id)).unwrap();
    }
    if let Ok(keep) = std::env::var("TRINOCULAR_KEEP_SCREENSHOT") {
        img.save(&keep).unwrap();
        eprintln!("screenshot saved to {keep}");
    }
}

#[test]
fn harness_catches_console_errors_and_blank_plots() {
    let Some(browser) = browser_or_skip() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("bad.html");
    std::fs::write(
        &page,
        "<!DOCTYPE html><html><body><figure class=\"plot\" id=\"plot-blank\">\
         <svg width=\"400\" height=\"300\"><rect width=\"400\" height=\"300\" fill=\"white\"/></svg></figure>\
         <img src=\"missing.png\"><script>console.error('broken')</script></body></html>",
    )
    .unwrap();
    let (layout, img, errors) = render(&browser, &format!("file://{}", page.display()));
    assert!(
        errors.iter().any(|e| e.contains("broken")),
        "console.error missed: {errors:#?}"
    );
    assert!(
        errors.iter().any(|e| e.contains("missing.png")),
        "failed load missed: {errors:#?}"
    );
    let plots = boxes(&layout);
    assert_eq!(plots.len(), 1);
    assert!(
        check_region(&img, &plots[0], &[]).is_err(),
        "a blank plot passed"
    );
}

#[test]
fn base64_decodes() {
    assert_eq!(base64("aGVsbG8="), b"hello");
    assert_eq!(base64("aGVsbG8h"), b"hello!");
    assert_eq!(base64("aGk="), b"hi");
}
