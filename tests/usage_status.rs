//! Usage errors exit with status 2 on every command, with one line naming the
//! option and its fault, before any file is read or written: values out of
//! an option's domain (checked while parsing, or by the configuration the
//! options override) and options that do not fit together.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;
use std::process::{Command, Output};

/// (command line, fragment of the one-line message).
const CASES: &[(&[&str], &str)] = &[
    (
        &["synth", "campaign", "--out", "{out}", "--width", "0"],
        "--width: must be positive",
    ),
    (
        &["synth", "campaign", "--out", "{out}", "--targets", "1"],
        "--targets: 1: at least 2 targets",
    ),
    (
        &["synth", "campaign", "--out", "{out}", "--runs", "0"],
        "procedure.runs",
    ),
    (
        &["synth", "target", "--out", "{out}", "--height", "8"],
        "sensor.width/height",
    ),
    (
        &[
            "synth",
            "probe",
            "rotary",
            "--out",
            "{out}",
            "--step-deg",
            "400",
        ],
        "step_deg: 400",
    ),
    (
        &[
            "synth", "probe", "indexing", "--out", "{out}", "--a-step", "0",
        ],
        "a_step_deg",
    ),
    (
        &[
            "synth", "probe", "tracer", "--out", "{out}", "--counts", "1,2,2",
        ],
        "tracer.counts",
    ),
    (
        &[
            "synth",
            "probe",
            "volumetric",
            "--out",
            "{out}",
            "--chain",
            "WQF",
        ],
        "--chain 'WQF'",
    ),
    (
        &[
            "calibrate",
            "--target",
            "t.csv",
            "--nominal",
            "n.json",
            "--images",
            "a.tif",
            "--outlier-k",
            "0.5",
            "--out",
            "{out}/rig.json",
        ],
        "outlier k: 0.5",
    ),
    (
        &["extract", "--k", "nan", "--out", "{out}/b.csv", "a.tif"],
        "invalid value 'nan' for '--k <K>'",
    ),
    (
        &[
            "extract",
            "--threshold",
            "bright",
            "--out",
            "{out}/b.csv",
            "a.tif",
        ],
        "'bright' for '--threshold",
    ),
    (
        &[
            "extract",
            "--min-area",
            "100",
            "--max-area",
            "10",
            "--out",
            "{out}/b.csv",
            "a.tif",
        ],
        "min_area 100 exceeds max_area 10",
    ),
    (
        &[
            "extract",
            "--denoise",
            "gaussian",
            "--sigma=-1",
            "--out",
            "{out}/b.csv",
            "a.tif",
        ],
        "'--sigma <SIGMA>'",
    ),
    (
        &[
            "measure",
            "--rig",
            "r.json",
            "--manifest",
            "m.csv",
            "--spheres",
            "s.csv",
            "--out",
            "{out}/p.csv",
            "--k=-2",
        ],
        "invalid value '-2' for '--k <K>'",
    ),
    (
        &[
            "probe",
            "rotary",
            "--centres",
            "c.csv",
            "--out",
            "{out}",
            "--at",
            "nan",
        ],
        "'--at <DEG>...'",
    ),
    (
        &[
            "probe",
            "indexing",
            "--centres",
            "c.csv",
            "--out",
            "{out}",
            "--tolerance=-1",
        ],
        "'--tolerance <ARCSEC>'",
    ),
    (
        &[
            "probe",
            "indexing",
            "--centres",
            "c.csv",
            "--out",
            "{out}",
            "--nominal-radius",
            "0",
        ],
        "'--nominal-radius <MM>'",
    ),
    (
        &[
            "probe",
            "tracer",
            "--nominal",
            "g.csv",
            "--readings",
            "r.csv",
            "--out",
            "{out}",
            "--k",
            "0",
        ],
        "'--k <K>'",
    ),
    (
        &[
            "probe",
            "tracer",
            "--nominal",
            "g.csv",
            "--readings",
            "r.csv",
            "--out",
            "{out}",
            "--sigma-um",
            "inf",
        ],
        "'--sigma-um <UM>'",
    ),
    (
        &[
            "probe",
            "volumetric",
            "--errors",
            "e.csv",
            "--out",
            "{out}",
            "--chain",
            "XYZ",
        ],
        "--chain 'XYZ'",
    ),
    (
        &["bench", "extract", "--repeat", "0"],
        "'--repeat <REPEAT>'",
    ),
    (
        &["demo", "--out", "{out}/demo", "--targets", "1"],
        "--targets: 1",
    ),
];

/// Run a case's command line in `dir`, `{out}` replaced by `out`: the
/// arguments as run and what the run gave.
fn run_case(dir: &Path, out: &Path, args: &[&str]) -> (Vec<String>, Output) {
    let args: Vec<String> = args
        .iter()
        .map(|a| a.replace("{out}", out.to_str().unwrap()))
        .collect();
    let run = Command::new(env!("CARGO_BIN_EXE_trinocular"))
        .args(&args)
        .current_dir(dir)
        .env("TRINOCULAR_NO_GPU", "1")
        .output()
        .unwrap();
    (args, run)
}

#[test]
fn usage_errors_exit_2_with_one_line_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let mut failures = Vec::new();
    for (i, (args, fragment)) in CASES.iter().enumerate() {
        let out = dir.path().join(format!("case{i}"));
        let (args, run) = run_case(dir.path(), &out, args);
        let err = String::from_utf8_lossy(&run.stderr);
        let lines: Vec<&str> = err.trim_end().lines().collect();
        // The demo prints each step before running it; the others say one line.
        let demo = args[0] == "demo";
        let last = lines.last().copied().unwrap_or("");
        let ok = run.status.code() == Some(2)
            && (lines.len() == 1 || demo)
            && last.starts_with("trinocular: error: ")
            && last.contains(fragment)
            // The demo makes its output folder before its first step.
            && (!out.exists()
                || demo && std::fs::read_dir(out.join("demo")).is_ok_and(|d| d.count() == 0));
        if !ok {
            failures.push(format!(
                "{}: status {:?}, stderr {err:?}",
                args.join(" "),
                run.status.code()
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Command lines clap refuses while parsing, and what the message must name.
const PARSE_CASES: &[(&[&str], &[&str])] = &[
    (&["measure", "--bogus"], &["'--bogus'"]),
    // Without input, both ways of giving the curves are named.
    (
        &["probe", "volumetric", "--out", "{out}"],
        &["--errors", "--from-report"],
    ),
    (&["synth", "probe", "rotary"], &["--out", "--print-config"]),
    (
        &["synth", "probe", "indexing"],
        &["--out", "--print-config"],
    ),
];

/// The subcommand a command line names: its leading words.
fn subcommand(args: &[String]) -> String {
    let words: Vec<&str> = args
        .iter()
        .take_while(|a| !a.starts_with('-'))
        .map(String::as_str)
        .collect();
    format!("trinocular {}", words.join(" "))
}

#[test]
fn usage_errors_point_to_the_subcommands_help() {
    let dir = tempfile::tempdir().unwrap();
    let cases = CASES
        .iter()
        .map(|(args, fragment)| (*args, vec![*fragment]))
        .chain(
            PARSE_CASES
                .iter()
                .map(|(args, fragments)| (*args, fragments.to_vec())),
        );
    let mut failures = Vec::new();
    for (i, (args, fragments)) in cases.enumerate() {
        let out = dir.path().join(format!("case{i}"));
        let (args, run) = run_case(dir.path(), &out, args);
        let err = String::from_utf8_lossy(&run.stderr);
        let last = err.trim_end().lines().last().unwrap_or("").to_string();
        let help = format!("(see '{} --help')", subcommand(&args));
        if run.status.code() != Some(2)
            || !last.ends_with(&help)
            || fragments.iter().any(|f| !last.contains(f))
        {
            failures.push(format!(
                "{}: want {help} and {fragments:?}, got {err:?}",
                args.join(" ")
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// An option that a command cannot run without shows as required in its
/// `--help` (clap's usage line lists it outside `[OPTIONS]`).
#[test]
fn help_shows_the_required_options() {
    for (args, required) in [
        (
            &["synth", "probe", "rotary"][..],
            "<--out <OUT>|--print-config>",
        ),
        (
            &["synth", "probe", "indexing"],
            "<--out <DIR>|--print-config>",
        ),
        (&["synth", "probe", "tracer"], "--out <DIR>"),
        (&["synth", "probe", "volumetric"], "--out <OUT>"),
        (
            &["probe", "volumetric"],
            "<--errors <E.csv>|--from-report <DIR>>",
        ),
        (&["measure"], "--out <OUT>"),
    ] {
        let run = Command::new(env!("CARGO_BIN_EXE_trinocular"))
            .args(args)
            .arg("--help")
            .output()
            .unwrap();
        let help = String::from_utf8_lossy(&run.stdout);
        let usage = help
            .lines()
            .find(|l| l.starts_with("Usage:"))
            .unwrap_or_default();
        assert!(usage.contains(required), "{args:?}: {usage}");
    }
}
