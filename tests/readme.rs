//! The README's shell blocks run as written on a fresh machine: each block
//! that a test machine can run runs here, in a folder of its own, with the
//! built `trinocular` first on the PATH, and must exit 0. A block that cannot
//! run here is listed in [`NOT_RUN`] with the reason and where else it is
//! held; a block that is neither run nor listed fails the test, so a new
//! README block is dealt with. Every `trinocular` command of every block,
//! those not run included, also parses (src/main.rs,
//! `every_readme_command_parses`).

#![allow(clippy::unwrap_used, clippy::expect_used)]

#[path = "common/readme_blocks.rs"]
mod readme_blocks;

use std::path::Path;
use std::process::Command;

/// Blocks not run here, by the start of their first line, with the reason.
const NOT_RUN: &[(&str, &str)] = &[
    (
        "cargo install",
        "installs into ~/.cargo/bin; the tests run the binary cargo built",
    ),
    (
        "cargo run --release -- demo",
        "a release build of its own; tests/demo.rs runs the same demo and holds its table",
    ),
    ("cargo test --workspace", "this is the test run itself"),
    (
        "trinocular synth config > rig.toml",
        "renders the full seed campaign (850 GB); its other lines run in other blocks",
    ),
    (
        "trinocular extract --out blobs.csv images/",
        "names the reader's own images; tests/cli.rs and tests/bad_input.rs run extract",
    ),
    (
        "trinocular measure --rig rig.json --manifest manifest.csv",
        "names the reader's own campaign; the walk-through block runs the same command",
    ),
    (
        "trinocular evaluate --points points.csv --out report/",
        "names the reader's own points; the walk-through block runs the same command",
    ),
    (
        "(ulimit -v 4194304; cargo test --test fuzz",
        "the long fuzzing run (an ignored test)",
    ),
    ("cargo build --release", "needs a GPU and a release build"),
];

#[test]
fn readme_blocks_run_as_written() {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    // `trinocular` on the PATH is the binary under test.
    let bin = dir.path().join("bin");
    std::fs::create_dir(&bin).unwrap();
    std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_trinocular"), bin.join("trinocular")).unwrap();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );

    let mut failures = Vec::new();
    let mut ran = 0;
    for block in readme_blocks::sh_blocks(&readme) {
        let first = block.text.lines().next().unwrap_or("");
        if NOT_RUN.iter().any(|(start, _)| first.starts_with(start)) {
            continue;
        }
        let here = dir.path().join(format!("block{}", block.line));
        std::fs::create_dir(&here).unwrap();
        let run = Command::new("bash")
            .args(["-euo", "pipefail", "-c", &block.text])
            .current_dir(&here)
            .env("PATH", &path)
            .env("TRINOCULAR_NO_GPU", "1")
            .output()
            .unwrap();
        ran += 1;
        if !run.status.success() {
            failures.push(format!(
                "README line {}: status {:?}\n{}\n{}",
                block.line,
                run.status.code(),
                block.text,
                String::from_utf8_lossy(&run.stderr)
            ));
        }
    }
    assert!(ran >= 4, "only {ran} blocks ran");
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

/// Every block the list names is still in the README (a stale entry would
/// hide nothing, but says something untrue).
#[test]
fn blocks_not_run_are_in_the_readme() {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md")).unwrap();
    let blocks = readme_blocks::sh_blocks(&readme);
    for (start, _) in NOT_RUN {
        assert!(
            blocks.iter().any(|b| b.text.starts_with(start)),
            "no README block starts with {start:?}"
        );
    }
}
