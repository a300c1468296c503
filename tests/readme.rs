//! The shell blocks of the README and of its guides in `docs/` run as
//! written on a fresh machine: each block that a test machine can run runs
//! here, in a folder of its own, with the built `trinocular` first on the
//! PATH, and must exit 0. A block that cannot run here is listed in
//! [`NOT_RUN`] with the reason and where else it is held; a block that is
//! neither run nor listed fails the test, so a new block is dealt with, and
//! a page with shell blocks that is not in `readme_blocks::PAGES` fails too.
//! Every `trinocular` command of every block, those not run included, also
//! parses (src/main.rs, `every_readme_command_parses`). And every relative
//! link of README.md, ARCHITECTURE.md and `docs/` reaches its file and
//! heading.

#![allow(clippy::unwrap_used, clippy::expect_used)]

#[path = "common/readme_blocks.rs"]
mod readme_blocks;

use readme_blocks::{PAGES, read_page, sh_blocks};
use std::path::Path;
use std::process::Command;

/// Blocks not run here: their page, the start of their first line, and the
/// reason.
const NOT_RUN: &[(&str, &str, &str)] = &[
    (
        "README.md",
        "cargo install",
        "installs into ~/.cargo/bin; the tests run the binary cargo built",
    ),
    (
        "README.md",
        "cargo run --release -- demo",
        "a release build of its own; tests/demo.rs runs the same demo and holds its table",
    ),
    (
        "README.md",
        "cargo test --workspace",
        "this is the test run itself",
    ),
    (
        "docs/synthetic-campaigns.md",
        "trinocular synth config > rig.toml",
        "renders the full seed campaign (850 GB); its other lines run in other blocks",
    ),
    (
        "docs/extracting.md",
        "trinocular extract --out blobs.csv images/",
        "names the reader's own images; tests/cli.rs and tests/bad_input.rs run extract",
    ),
    (
        "docs/measuring.md",
        "trinocular measure --rig rig.json --manifest manifest.csv",
        "names the reader's own campaign; the README's walk-through runs the same command",
    ),
    (
        "docs/ingest.md",
        "trinocular manifest --program program.toml",
        "names the reader's own folders; the worked example below it runs the same command",
    ),
    (
        "docs/evaluating.md",
        "trinocular evaluate --points points.csv --out report/",
        "names the reader's own points; the README's walk-through runs the same command",
    ),
    (
        "docs/bad-input.md",
        "(ulimit -v 4194304; cargo test --test fuzz",
        "the long fuzzing run (an ignored test)",
    ),
    (
        "docs/gpu.md",
        "cargo build --release",
        "needs a GPU and a release build",
    ),
];

/// Whether the block of `page` whose first line is `first` is listed in
/// [`NOT_RUN`].
fn not_run(page: &str, first: &str) -> bool {
    NOT_RUN
        .iter()
        .any(|(p, start, _)| *p == page && first.starts_with(start))
}

#[test]
fn readme_blocks_run_as_written() {
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
    for page in PAGES {
        for block in sh_blocks(&read_page(page)) {
            let first = block.text.lines().next().unwrap_or("");
            if not_run(page, first) {
                continue;
            }
            let here = dir
                .path()
                .join(format!("{}-{}", page.replace('/', "-"), block.line));
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
                    "{page} line {}: status {:?}\n{}\n{}",
                    block.line,
                    run.status.code(),
                    block.text,
                    String::from_utf8_lossy(&run.stderr)
                ));
            }
        }
    }
    assert!(ran >= 5, "only {ran} blocks ran");
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

/// Every block the list names is still on its page (a stale entry would
/// hide nothing, but says something untrue).
#[test]
fn blocks_not_run_are_on_their_pages() {
    for (page, start, _) in NOT_RUN {
        assert!(
            PAGES.contains(page),
            "{page} is not in readme_blocks::PAGES"
        );
        assert!(
            sh_blocks(&read_page(page))
                .iter()
                .any(|b| b.text.starts_with(start)),
            "no block of {page} starts with {start:?}"
        );
    }
}

/// Every page of the README and `docs/` that shows shell blocks is held: a
/// guide added with a block, or a block added to another page, is run or
/// listed as not run like the rest.
#[test]
fn every_page_with_shell_blocks_is_held() {
    let pages = repository_pages();
    let unheld: Vec<&String> = pages
        .iter()
        .filter(|p| !PAGES.contains(&p.as_str()) && !sh_blocks(&read_page(p)).is_empty())
        .collect();
    assert!(
        unheld.is_empty(),
        "pages with shell blocks missing from readme_blocks::PAGES: {unheld:?}"
    );
}

/// The pages of [`every_page_with_shell_blocks_is_held`] and the links
/// check: README.md, ARCHITECTURE.md and every page of `docs/`.
fn repository_pages() -> Vec<String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut pages = vec!["README.md".to_string(), "ARCHITECTURE.md".to_string()];
    let mut docs: Vec<String> = std::fs::read_dir(root.join("docs"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|name| name.ends_with(".md"))
        .map(|name| format!("docs/{name}"))
        .collect();
    docs.sort();
    pages.extend(docs);
    pages
}

/// A page's lines outside fenced code blocks.
fn prose(page: &str) -> Vec<String> {
    let mut fenced = false;
    let mut lines = Vec::new();
    for line in page.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        } else if !fenced {
            lines.push(line.to_string());
        }
    }
    lines
}

/// The anchors of a page's headings, as GitHub makes them: the text
/// lowercased, every character but letters, digits, spaces, `-` and `_`
/// dropped, spaces turned into `-`; a repeated anchor takes `-1`, `-2`, ….
fn anchors(page: &str) -> Vec<String> {
    let mut anchors: Vec<String> = Vec::new();
    let mut slugs: Vec<String> = Vec::new();
    for line in prose(page) {
        let Some(title) = line
            .strip_prefix('#')
            .map(|t| t.trim_start_matches('#'))
            .filter(|t| t.starts_with(' '))
        else {
            continue;
        };
        let slug: String = title
            .trim()
            .to_lowercase()
            .chars()
            .filter(|c| c.is_alphanumeric() || matches!(c, ' ' | '-' | '_'))
            .map(|c| if c == ' ' { '-' } else { c })
            .collect();
        let repeats = slugs.iter().filter(|s| **s == slug).count();
        anchors.push(if repeats == 0 {
            slug.clone()
        } else {
            format!("{slug}-{repeats}")
        });
        slugs.push(slug);
    }
    anchors
}

/// Every relative link `[text](path#anchor)` of README.md, ARCHITECTURE.md
/// and `docs/` names a file of the repository and, with an anchor, a heading
/// of that page: moving a section elsewhere breaks no link to it.
#[test]
fn relative_links_resolve() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut broken = Vec::new();
    let mut checked = 0;
    for page in repository_pages() {
        let here = Path::new(&page).parent().unwrap_or(Path::new(""));
        for line in prose(&read_page(&page)) {
            for (at, _) in line.match_indices("](") {
                let rest = &line[at + 2..];
                let Some(end) = rest.find(')') else { continue };
                let target = &rest[..end];
                if target.contains("://") || target.contains(' ') {
                    continue;
                }
                checked += 1;
                let (path, anchor) = target.split_once('#').unwrap_or((target, ""));
                let file = if path.is_empty() {
                    Path::new(&page).to_path_buf()
                } else {
                    here.join(path)
                };
                if !root.join(&file).exists() {
                    broken.push(format!("{page}: {target}: no file {}", file.display()));
                } else if !anchor.is_empty() {
                    let text = std::fs::read_to_string(root.join(&file)).unwrap_or_default();
                    if !anchors(&text).iter().any(|a| a == anchor) {
                        broken.push(format!(
                            "{page}: {target}: no heading #{anchor} in {}",
                            file.display()
                        ));
                    }
                }
            }
        }
    }
    assert!(checked >= 50, "only {checked} links found");
    assert!(broken.is_empty(), "{}", broken.join("\n"));
}
