//! The bad-input corpus (`testdata/bad/`, format in its README): every case
//! runs the binary on its small input files and must end with the expected
//! exit status, a message that names the file and the fault, the outputs it
//! lists, no panic, no abort, its own folder untouched and, when it fails,
//! its output folder as it was.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use serde::Deserialize;

/// One case: `testdata/bad/<case>/case.toml`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Case {
    /// What the case shows, one line.
    about: String,
    /// Items of issue 12 it covers (informative).
    #[serde(default)]
    #[allow(dead_code)]
    issue: Vec<u32>,
    /// The command line after `trinocular`; `{out}` is a fresh empty folder.
    args: Vec<String>,
    /// Expected exit status.
    status: i32,
    /// Fragments that must all stand on one line of stderr.
    #[serde(default)]
    stderr: Vec<String>,
    /// Fragments that must not appear anywhere in stderr.
    #[serde(default)]
    not_stderr: Vec<String>,
    /// Files the run must leave in `{out}` (relative to it), each with
    /// fragments its text must hold.
    #[serde(default)]
    outputs: BTreeMap<String, Vec<String>>,
    /// Files the run must not leave in `{out}`.
    #[serde(default)]
    absent: Vec<String>,
    /// Fragments that must each stand somewhere in stderr (notes on lines
    /// of their own, beside the `stderr` line).
    #[serde(default)]
    notes: Vec<String>,
    /// Files of the case's `out/` folder — copied into `{out}` before the
    /// run, as an earlier run left them — that the run must leave byte for
    /// byte as they were.
    #[serde(default)]
    unchanged: Vec<String>,
    /// Address-space limit of the run (MiB): a huge allocation fails there
    /// (an abort) instead of swapping.
    #[serde(default = "default_memory_mib")]
    memory_mib: u64,
    /// Wall-clock limit of the run (s).
    #[serde(default = "default_timeout_s")]
    timeout_s: u64,
}

fn default_memory_mib() -> u64 {
    4096
}

fn default_timeout_s() -> u64 {
    120
}

fn corpus() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("testdata/bad")
}

/// Every file below `dir` with its bytes (the case folder must not change).
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Option<Vec<u8>>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path.clone());
                out.insert(path, None);
            } else {
                out.insert(path.clone(), Some(std::fs::read(&path).unwrap()));
            }
        }
    }
    out
}

/// Run one case; `Err` says what went wrong.
fn run(dir: &Path) -> Result<(), String> {
    let text = std::fs::read_to_string(dir.join("case.toml")).map_err(|e| e.to_string())?;
    let case: Case = toml::from_str(&text).map_err(|e| format!("case.toml: {e}"))?;
    if case.about.trim().is_empty() || case.args.is_empty() {
        return Err("case.toml: `about` and `args` must not be empty".into());
    }
    if !(1..=3).contains(&case.status) {
        return Err("case.toml: a bad-input case expects status 1, 2 or 3".into());
    }
    if case.stderr.is_empty() && case.outputs.is_empty() {
        return Err("case.toml: give the message fragments (`stderr` or `outputs`)".into());
    }
    let out = tempfile::tempdir().map_err(|e| e.to_string())?;
    let out_text = out.path().to_str().ok_or("temporary folder is not UTF-8")?;
    let args: Vec<String> = case
        .args
        .iter()
        .map(|a| a.replace("{out}", out_text))
        .collect();
    // What an earlier run left in the output folder.
    let earlier = dir.join("out");
    if earlier.is_dir() {
        for (path, bytes) in snapshot(&earlier) {
            let to = out
                .path()
                .join(path.strip_prefix(&earlier).map_err(|e| e.to_string())?);
            let Some(bytes) = bytes else {
                std::fs::create_dir_all(&to).map_err(|e| e.to_string())?;
                continue;
            };
            if let Some(parent) = to.parent() {
                std::fs::create_dir_all(parent).map_err(|e| e.to_string())?;
            }
            std::fs::write(&to, bytes).map_err(|e| e.to_string())?;
        }
    }
    let before = snapshot(dir);
    let out_before = snapshot(out.path());
    // The limit is set by the shell that then becomes the binary.
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v {} && exec \"$0\" \"$@\"",
            case.memory_mib * 1024
        ))
        .arg(env!("CARGO_BIN_EXE_trinocular"))
        .args(&args)
        .current_dir(dir)
        .env("TRINOCULAR_NO_GPU", "1")
        .env("RUST_BACKTRACE", "0")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| e.to_string())?;
    let start = Instant::now();
    let limit = Duration::from_secs(case.timeout_s);
    while child.try_wait().map_err(|e| e.to_string())?.is_none() {
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!("still running after {} s", case.timeout_s));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let output = child.wait_with_output().map_err(|e| e.to_string())?;
    let stderr = String::from_utf8_lossy(&output.stderr).replace(out_text, "{out}");
    let mut faults = Vec::new();
    if output.status.code() != Some(case.status) {
        faults.push(format!(
            "exit status {:?}, expected {}",
            output.status.code(),
            case.status
        ));
    }
    for marker in ["panicked", "memory allocation of", "RUST_BACKTRACE"] {
        if stderr.contains(marker) {
            faults.push(format!("stderr holds «{marker}»: a panic or an abort"));
        }
    }
    if case.status != 3 {
        let last = stderr.lines().last().unwrap_or_default();
        if !last.starts_with("trinocular: error: ") {
            faults.push("the last line of stderr is not `trinocular: error: …`".into());
        }
    }
    if !case.stderr.is_empty()
        && !stderr
            .lines()
            .any(|l| case.stderr.iter().all(|f| l.contains(f.as_str())))
    {
        faults.push(format!("no line of stderr holds all of {:?}", case.stderr));
    }
    for f in &case.notes {
        if !stderr.contains(f.as_str()) {
            faults.push(format!("stderr does not hold «{f}»"));
        }
    }
    for name in &case.unchanged {
        let (was, is) = (
            std::fs::read(earlier.join(name)).map_err(|e| format!("out/{name}: {e}"))?,
            std::fs::read(out.path().join(name)),
        );
        if is.ok().as_ref() != Some(&was) {
            faults.push(format!("{name} of the earlier run was replaced or removed"));
        }
    }
    for f in &case.not_stderr {
        if stderr.contains(f.as_str()) {
            faults.push(format!("stderr holds «{f}»"));
        }
    }
    for (name, fragments) in &case.outputs {
        match std::fs::read_to_string(out.path().join(name)) {
            Ok(text) => {
                let text = text.replace(out_text, "{out}");
                for f in fragments {
                    if !text.contains(f.as_str()) {
                        faults.push(format!("{name} does not hold «{f}»"));
                    }
                }
            }
            Err(e) => faults.push(format!("{name}: {e}")),
        }
    }
    for name in &case.absent {
        if out.path().join(name).exists() {
            faults.push(format!("{name} was written"));
        }
    }
    if snapshot(dir) != before {
        faults.push("the run changed the case folder (it must write into {out} only)".into());
    }
    if case.status != 3 && snapshot(out.path()) != out_before {
        faults.push("a failed run left {out} changed (it must leave it as it was)".into());
    }
    if faults.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "{}\n      args: {:?}\n      stderr: {}",
            faults.join("\n      "),
            case.args,
            stderr.trim_end().replace('\n', "\n              ")
        ))
    }
}

#[test]
fn every_case_of_the_bad_input_corpus() {
    let mut cases: Vec<PathBuf> = std::fs::read_dir(corpus())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.join("case.toml").is_file())
        .collect();
    cases.sort();
    // One case by name: TRINOCULAR_BAD_CASE=<folder name>.
    if let Ok(only) = std::env::var("TRINOCULAR_BAD_CASE") {
        cases.retain(|c| c.file_name().is_some_and(|n| n == only.as_str()));
    }
    assert!(!cases.is_empty(), "no cases under {}", corpus().display());
    let mut failed = Vec::new();
    for dir in &cases {
        let name = dir.file_name().unwrap().to_string_lossy().into_owned();
        if let Err(e) = run(dir) {
            failed.push(format!("{name}: {e}"));
        }
    }
    assert!(
        failed.is_empty(),
        "{} of {} cases failed:\n  {}",
        failed.len(),
        cases.len(),
        failed.join("\n  ")
    );
    eprintln!("{} cases passed", cases.len());
}
