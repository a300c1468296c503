//! Helpers of the binary's integration tests: running `trinocular` and
//! judging what it printed and left behind. Each test file uses a part.

#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The binary under test.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_trinocular"))
}

/// Run the binary with `args`.
pub fn trinocular(args: &[&str]) -> Output {
    bin().args(args).output().expect("run trinocular")
}

/// A path as an argument.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A file of the repository's `testdata/`.
pub fn testdata(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("testdata")
        .join(rel)
}

/// A file of a probe method's check data, `testdata/probe/METHOD/NAME`.
pub fn probe_data(method: &str, name: &str) -> PathBuf {
    testdata("probe").join(method).join(name)
}

/// The bytes of a file; a missing one fails the test with its name.
pub fn read(p: &Path) -> Vec<u8> {
    std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Stderr as text.
pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Stdout of a run that must succeed.
pub fn ok_stdout(out: &Output) -> String {
    ok(out);
    String::from_utf8(out.stdout.clone()).unwrap()
}

/// A successful run; returns its stderr.
pub fn ok(out: &Output) -> String {
    assert!(
        out.status.success(),
        "{:?}: {}{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        stderr(out)
    );
    stderr(out)
}

/// A failed run whose stderr is exactly one line starting with the program
/// name: its exit status and that line.
pub fn failure(out: &Output) -> (i32, String) {
    assert!(
        !out.status.success(),
        "expected failure: {}",
        String::from_utf8_lossy(&out.stdout)
    );
    let err = stderr(out);
    assert_eq!(err.trim_end().lines().count(), 1, "not one line: {err:?}");
    assert!(err.starts_with("trinocular: error: "), "{err:?}");
    (out.status.code().unwrap(), err)
}

/// The line of a failed run ([`failure`]).
pub fn one_line_error(out: &Output) -> String {
    failure(out).1
}

/// The line of a run refused with exit status 1 ([`failure`]).
pub fn one_line_refusal(out: &Output) -> String {
    let (code, err) = failure(out);
    assert_eq!(code, 1, "{err}");
    err
}

/// A refused run: exit status 1 and an error line holding every fragment.
pub fn refused(out: &Output, fragments: &[&str]) -> String {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    let line = err
        .lines()
        .find(|l| l.starts_with("trinocular: error: "))
        .unwrap_or_else(|| panic!("no error line: {err}"));
    for f in fragments {
        assert!(line.contains(f), "'{f}' missing from {line}");
    }
    line.to_string()
}

/// Files under `dir` (recursively) whose name marks a temporary file, a
/// staging folder or a lock.
pub fn leftovers(dir: &Path) -> Vec<PathBuf> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap().flatten() {
        let path = entry.path();
        let name = entry.file_name().to_string_lossy().into_owned();
        if name.ends_with(".tmp") || name == ".trinocular.lock" {
            found.push(path.clone());
        }
        if path.is_dir() {
            found.extend(leftovers(&path));
        }
    }
    found
}

/// Render a small campaign into `out` with `synth campaign`: `size` (px),
/// `[targets, runs, captures]`, then `extra` arguments.
pub fn render_campaign(
    out: &Path,
    (width, height): (u32, u32),
    [targets, runs, captures]: [u32; 3],
    extra: &[&str],
) {
    let n = [width, height, targets, runs, captures].map(|n| n.to_string());
    let mut args = vec![
        "synth",
        "campaign",
        "--out",
        s(out),
        "--width",
        &n[0],
        "--height",
        &n[1],
        "--targets",
        &n[2],
        "--runs",
        &n[3],
        "--captures",
        &n[4],
    ];
    args.extend(extra);
    ok(&trinocular(&args));
}

/// The renderer's true cameras of the campaign `c` (its `truth.json`) written
/// as the rig `rig`: measurements then judge fusion alone. Returns the truth.
pub fn write_true_rig(c: &Path, rig: &Path) -> formats::Truth {
    let truth: formats::Truth = formats::read_json(&c.join("truth.json")).unwrap();
    let cameras = truth
        .cameras
        .iter()
        .map(|t| formats::RigCamera::new(t.model.id, &t.model.to_camera().unwrap(), 0.0, 0))
        .collect();
    formats::write_json(rig, &formats::Rig { cameras }).unwrap();
    truth
}

/// `args` run, run again and refused (exit status 1, one line that names
/// `--force`), then run with `--force`: `written` as before. Returns the
/// refusal.
pub fn kept_unless_forced(args: &[&str], written: &Path) -> String {
    ok(&trinocular(args));
    let before = read(written);
    let err = one_line_refusal(&trinocular(args));
    assert!(err.contains("--force"), "{err}");
    let mut forced = args.to_vec();
    forced.push("--force");
    ok(&trinocular(&forced));
    assert_eq!(read(written), before, "same input, same output");
    err
}

/// Every file and folder under `dir`, with each file's bytes (`None` for a
/// folder): what a failed run must leave exactly as it was.
pub fn tree(dir: &Path) -> std::collections::BTreeMap<PathBuf, Option<Vec<u8>>> {
    let mut found = std::collections::BTreeMap::new();
    for entry in std::fs::read_dir(dir).unwrap().flatten() {
        let path = entry.path();
        if path.is_dir() {
            found.extend(tree(&path));
            found.insert(path, None);
        } else {
            found.insert(path.clone(), Some(read(&path)));
        }
    }
    found
}

/// Heikkilä's target and correspondences in `dir`, `u_mm` per marker when given.
pub fn heikkila(dir: &Path, u_mm: Option<&str>) -> (PathBuf, PathBuf) {
    let data = std::fs::read_to_string(testdata("heikkila/data3d.csv")).unwrap();
    let header = if u_mm.is_some() {
        "id,x,y,z,u_mm\n"
    } else {
        "id,x,y,z\n"
    };
    let (mut target, mut points) = (String::from(header), String::from("id,u,v\n"));
    for (i, line) in data.lines().skip(1).enumerate() {
        let f: Vec<&str> = line.split(',').collect();
        target.push_str(&format!("{},{},{},{}", i + 1, f[0], f[1], f[2]));
        if let Some(u) = u_mm {
            target.push_str(&format!(",{u}"));
        }
        target.push('\n');
        points.push_str(&format!("{},{},{}\n", i + 1, f[3], f[4]));
    }
    let (t, p) = (dir.join("target.csv"), dir.join("points.csv"));
    std::fs::write(&t, target).unwrap();
    std::fs::write(&p, points).unwrap();
    (t, p)
}

/// The two-halves check of `calibrate --views` (its stdout `said`): the
/// "M of N" grid points within twice the predicted difference.
pub fn halves(said: &str) -> (usize, usize) {
    let line = said
        .lines()
        .find(|l| l.starts_with("two halves"))
        .unwrap_or_else(|| panic!("no two-halves line: {said}"));
    let tail = line.rsplit("; ").next().unwrap_or_default();
    let words: Vec<&str> = tail.split_whitespace().collect();
    (words[0].parse().unwrap(), words[2].parse().unwrap())
}
