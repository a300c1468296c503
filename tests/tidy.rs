//! Tidy checks (rust-analyzer style): ARCHITECTURE.md's invariant "the
//! binary is thin" as a test over the source text of `src/`.
//!
//! The binary parses flags, reads and writes files through `formats`, calls
//! the library crates and prints; it computes nothing itself. The rule,
//! checked line by line on every `.rs` file under `src/` (comments excluded):
//!
//! 1. **No linear algebra**: no mention of `nalgebra` (`geom::nalgebra` included).
//! 2. **geom's plain types only**: every path `geom::NAME` and every name in a
//!    `use geom::{…}` list is one of the plain value types that the binary
//!    passes between libraries ([`PLAIN_TYPES`]: points, vectors, the camera
//!    and illumination models, the error) — never a module of geometric
//!    maths (`fit`, `min_zone`, `stats`, `sphere_image`, `camera`, …).
//!    One exception, [`GEOM_FRONT_ENDS`]: the `fit` command is the command
//!    line of geom's fitting functions (it reads points, calls one fit and
//!    prints its result).
//! 3. **No floating-point maths**: no call of a transcendental or root
//!    method of `f64` ([`FLOAT_MATHS`]: `.sqrt(`, `.hypot(`, `.atan2(`, …):
//!    a formula belongs to the crate of its idea, documented and tested there.

use std::path::{Path, PathBuf};

/// geom items the binary may name: plain values passed through.
const PLAIN_TYPES: &[&str] = &[
    "Camera",
    "GeomError",
    "Illumination",
    "Point2",
    "Point3",
    "RadialIllumination",
    "Vector2",
    "Vector3",
];

/// Files (relative to `src/`) that are the command line of a geom module,
/// and the modules they may call.
const GEOM_FRONT_ENDS: &[(&str, &[&str])] = &[("cmd/fit.rs", &["fit", "min_zone", "stats"])];

/// Float methods that mean a formula is being evaluated.
const FLOAT_MATHS: &[&str] = &[
    "sqrt",
    "cbrt",
    "powi",
    "powf",
    "exp",
    "exp2",
    "ln",
    "log",
    "log2",
    "log10",
    "sin",
    "cos",
    "tan",
    "sin_cos",
    "asin",
    "acos",
    "atan",
    "atan2",
    "sinh",
    "cosh",
    "tanh",
    "hypot",
    "mul_add",
    "to_radians",
    "to_degrees",
];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.map(|e| e.path()).unwrap_or_else(|e| panic!("{e}")))
        .collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The code of a line: without a `//` comment (doc comments included).
fn code(line: &str) -> &str {
    line.find("//").map_or(line, |i| &line[..i])
}

/// Names after `geom::` on a line: `geom::A`, `geom::{A, B}`, `geom::a::B` (→ `a`).
fn geom_names(line: &str) -> Vec<String> {
    let mut names = Vec::new();
    let mut rest = line;
    while let Some(i) = rest.find("geom::") {
        let before = rest[..i].chars().next_back();
        rest = &rest[i + "geom::".len()..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            continue;
        }
        if let Some(list) = rest.strip_prefix('{') {
            let end = list.find('}').unwrap_or(list.len());
            names.extend(
                list[..end]
                    .split(',')
                    .map(|n| n.trim().split("::").next().unwrap_or("").trim().to_string())
                    .filter(|n| !n.is_empty()),
            );
        } else {
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            names.push(name);
        }
    }
    names
}

fn violations(relative: &str, text: &str) -> Vec<String> {
    let allowed_modules: &[&str] = GEOM_FRONT_ENDS
        .iter()
        .find(|(file, _)| *file == relative)
        .map_or(&[], |(_, modules)| modules);
    let mut found = Vec::new();
    // `use geom::{` lists that span lines are joined first.
    let mut joined = Vec::new();
    let mut open: Option<(usize, String)> = None;
    for (i, line) in text.lines().enumerate() {
        let c = code(line);
        match &mut open {
            Some((_, acc)) => {
                acc.push_str(c);
                if c.contains('}') {
                    joined.push(open.take().unwrap_or_default());
                }
            }
            None if c.contains("geom::{") && !c.contains('}') => open = Some((i, c.to_string())),
            None => joined.push((i, c.to_string())),
        }
    }
    for (i, c) in joined {
        let at = format!("src/{relative}:{}", i + 1);
        if c.contains("nalgebra") {
            found.push(format!("{at}: names nalgebra"));
        }
        for name in geom_names(&c) {
            if !PLAIN_TYPES.contains(&name.as_str()) && !allowed_modules.contains(&name.as_str()) {
                found.push(format!("{at}: geom::{name} is not a plain type"));
            }
        }
        for m in FLOAT_MATHS {
            let call = format!(".{m}(");
            if c.contains(&call) {
                found.push(format!("{at}: float maths `{call}`"));
            }
        }
    }
    found
}

#[test]
fn the_binary_is_thin() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    assert!(
        files.len() > 10,
        "found only {} files under src/",
        files.len()
    );
    let mut found = Vec::new();
    for path in &files {
        let text =
            std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let relative = path
            .strip_prefix(&src)
            .unwrap_or(path)
            .to_string_lossy()
            .replace('\\', "/");
        found.extend(violations(&relative, &text));
    }
    assert!(
        found.is_empty(),
        "domain logic in the binary (tests/tidy.rs states the rule; move it to its crate):\n{}",
        found.join("\n")
    );
}

#[test]
fn the_rule_catches_what_it_states() {
    let bad = "use geom::nalgebra::Point3;\nuse geom::{Point2,\n    fit};\nlet d = x.hypot(y);\nlet s = geom::stats::rms(&r);\n";
    let found = violations("cmd/other.rs", bad);
    assert_eq!(
        found,
        [
            "src/cmd/other.rs:1: names nalgebra",
            "src/cmd/other.rs:1: geom::nalgebra is not a plain type",
            "src/cmd/other.rs:2: geom::fit is not a plain type",
            "src/cmd/other.rs:4: float maths `.hypot(`",
            "src/cmd/other.rs:5: geom::stats is not a plain type",
        ]
    );
    let good =
        "use geom::{Camera, Point2};\n// geom::fit in a comment\nlet p = geom::Point3::origin();\n";
    assert!(violations("cmd/other.rs", good).is_empty());
    assert!(violations("cmd/fit.rs", "use geom::{Point2, fit, min_zone, stats};").is_empty());
}
