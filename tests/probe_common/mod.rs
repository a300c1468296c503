//! Helpers of the `trinocular probe …` binary tests (`tests/probe_*.rs`):
//! running the binary, the check data, and what a success or a refusal
//! looks like.

// Each test binary uses a part of them.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Run `trinocular ARGS…`.
pub fn trinocular(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_trinocular"))
        .args(args)
        .output()
        .expect("run trinocular")
}

/// A file of a method's check data, `testdata/probe/METHOD/NAME`.
pub fn testdata(method: &str, name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("testdata/probe")
        .join(method)
        .join(name)
}

/// A path as an argument.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Stdout of a run that must succeed.
pub fn ok(out: &Output) -> String {
    assert!(
        out.status.success(),
        "failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout.clone()).unwrap()
}

/// Stderr of a failed run: one line starting with the program name, and the exit status.
pub fn failure(out: &Output) -> (i32, String) {
    assert!(
        !out.status.success(),
        "expected failure: {}",
        String::from_utf8_lossy(&out.stdout)
    );
    let err = String::from_utf8(out.stderr.clone()).unwrap();
    assert_eq!(err.trim_end().lines().count(), 1, "not one line: {err:?}");
    assert!(err.starts_with("trinocular: error: "), "{err:?}");
    (out.status.code().unwrap(), err)
}

/// The line of a run refused with exit status 1 ([`failure`]).
pub fn refused(out: &Output) -> String {
    let (code, err) = failure(out);
    assert_eq!(code, 1, "{err}");
    err
}

/// `args` run, run again and refused (exit status 1, one line that names
/// `--force`), then run with `--force`: `written` as before. Returns the
/// refusal.
pub fn kept_unless_forced(args: &[&str], written: &Path) -> String {
    ok(&trinocular(args));
    let before = std::fs::read(written).unwrap();
    let err = refused(&trinocular(args));
    assert!(err.contains("--force"), "{err}");
    let mut forced = args.to_vec();
    forced.push("--force");
    ok(&trinocular(&forced));
    assert_eq!(
        std::fs::read(written).unwrap(),
        before,
        "same input, same output"
    );
    err
}
