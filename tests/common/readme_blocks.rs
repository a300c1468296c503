//! The shell blocks of the README and of the guides in `docs/` (fenced
//! ```sh, also indented inside a list item), and the `trinocular` command
//! lines in them: read by the test that runs the blocks (tests/readme.rs) and
//! by the binary's test that parses every command line (src/main.rs).

use std::path::Path;

/// The pages whose shell blocks are held, relative to the repository root:
/// the README and the guides it links to. tests/readme.rs checks that every
/// page of the README and `docs/` with a shell block is listed.
pub const PAGES: &[&str] = &[
    "README.md",
    "docs/synthetic-campaigns.md",
    "docs/calibrating.md",
    "docs/extracting.md",
    "docs/gpu.md",
    "docs/measuring.md",
    "docs/ingest.md",
    "docs/evaluating.md",
    "docs/probe-methods.md",
    "docs/bad-input.md",
    "docs/performance.md",
    "docs/formats.md",
    "docs/radiometry.md",
];

/// The text of a page of [`PAGES`] (or any file of the repository).
pub fn read_page(page: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(page);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A fenced `sh` block: its first line's number in its page (1-based) and
/// its text, the fence's indentation removed.
#[derive(Debug, Clone)]
pub struct Block {
    pub line: usize,
    pub text: String,
}

/// Every `sh` block of a page's text, in order.
pub fn sh_blocks(page: &str) -> Vec<Block> {
    let mut blocks = Vec::new();
    let mut open: Option<(usize, usize, String)> = None;
    for (i, line) in page.lines().enumerate() {
        let trimmed = line.trim_start();
        let indent = line.len() - trimmed.len();
        match open.take() {
            None => {
                if trimmed == "```sh" {
                    open = Some((i + 2, indent, String::new()));
                }
            }
            Some((start, _, text)) if trimmed == "```" => {
                blocks.push(Block { line: start, text });
            }
            Some((start, fence, mut text)) => {
                text.push_str(line.get(fence..).unwrap_or(trimmed));
                text.push('\n');
                open = Some((start, fence, text));
            }
        }
    }
    blocks
}

/// The arguments of each `trinocular` command in a block: continuation lines
/// joined, comments dropped, commands split at `&&` and `;` and cut at a
/// redirection or a pipe; a command
/// through `cargo run … -- ARGS` counts as `trinocular ARGS`.
#[allow(dead_code)] // src/main.rs's test reads it; tests/readme.rs does not
pub fn trinocular_commands(block: &str) -> Vec<Vec<String>> {
    let joined = block.replace("\\\n", " ");
    let mut commands = Vec::new();
    for line in joined.lines() {
        let code = match line.find(" #") {
            Some(at) => &line[..at],
            None if line.trim_start().starts_with('#') => "",
            None => line,
        };
        for command in code.split("&&").flat_map(|c| c.split(';')) {
            let words: Vec<&str> = command
                .split_whitespace()
                .map(|w| w.trim_matches(|c| c == '(' || c == ')'))
                .collect();
            let args = match words.iter().position(|w| w.ends_with("trinocular")) {
                Some(at) => &words[at + 1..],
                None if words.starts_with(&["cargo", "run"]) => {
                    match words.iter().position(|w| *w == "--") {
                        Some(at) => &words[at + 1..],
                        None => continue,
                    }
                }
                None => continue,
            };
            // A redirection or pipe ends the command's own arguments.
            let own = args
                .iter()
                .take_while(|w| !w.starts_with('>') && !w.starts_with('|'));
            commands.push(own.map(|w| w.to_string()).collect());
        }
    }
    commands
}
