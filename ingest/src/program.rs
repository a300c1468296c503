//! `program.toml`: the motion program the machine ran — the `[procedure]`
//! table of the renderer's configuration (`formats::ProcedureConfig`, same
//! keys and meaning). Other top-level tables are ignored, so a campaign's
//! `config.toml` serves as its program; inside `[procedure]` unknown keys are
//! errors, and every key that decides where and when frames are taken must
//! be given (a default would be a guess): `runs`, `captures`, `overshoot_mm`,
//! `fps`, `feed_mm_per_s`, `settle_s`, `axes` with `axis`, `start_mm`,
//! `length_mm`, `segments`, `lines_mm`. `start_time` is not used (camera
//! clocks are not trusted).

use std::path::Path;

use formats::ProcedureConfig;

use crate::{IngestError, Result};

/// Keys of `[procedure]` the program must state.
const REQUIRED: [&str; 7] = [
    "runs",
    "captures",
    "overshoot_mm",
    "fps",
    "feed_mm_per_s",
    "settle_s",
    "axes",
];

/// Keys of each `[[procedure.axes]]` entry the program must state.
const REQUIRED_AXIS: [&str; 5] = ["axis", "start_mm", "length_mm", "segments", "lines_mm"];

/// Read and check `program.toml`.
pub fn read_program(path: &Path) -> Result<ProcedureConfig> {
    let text = std::fs::read_to_string(path).map_err(|e| IngestError::io(path, e))?;
    parse_program(&text, path)
}

/// Parse and check a program's text; `path` names it in errors.
pub fn parse_program(text: &str, path: &Path) -> Result<ProcedureConfig> {
    let err = |message: String| IngestError::Program {
        path: path.to_path_buf(),
        message,
    };
    let table: toml::Table = toml::from_str(text).map_err(|e| err(toml_message(text, &e)))?;
    let procedure = table
        .get("procedure")
        .ok_or_else(|| err("no [procedure] table".into()))?;
    let toml::Value::Table(p) = procedure else {
        return Err(err("procedure is not a table".into()));
    };
    for key in REQUIRED {
        if !p.contains_key(key) {
            return Err(err(format!(
                "procedure.{key} is missing (the program must state it)"
            )));
        }
    }
    if let Some(toml::Value::Array(axes)) = p.get("axes") {
        for (i, a) in axes.iter().enumerate() {
            let toml::Value::Table(a) = a else {
                return Err(err(format!("procedure.axes[{i}] is not a table")));
            };
            for key in REQUIRED_AXIS {
                if !a.contains_key(key) {
                    return Err(err(format!(
                        "procedure.axes[{i}].{key} is missing (the program must state it)"
                    )));
                }
            }
        }
    }
    let program: ProcedureConfig = procedure
        .clone()
        .try_into()
        .map_err(|e: toml::de::Error| err(format!("procedure: {}", one_line(e.message()))))?;
    program
        .validate()
        .map_err(|e| err(format!("{}: {}", e.key, e.message)))?;
    if program.axes.is_empty() {
        return Err(err("procedure.axes: the program moves no axis".into()));
    }
    Ok(program)
}

fn one_line(s: &str) -> String {
    s.trim_end().replace('\n', " ")
}

/// A TOML syntax error with its line and column.
fn toml_message(text: &str, e: &toml::de::Error) -> String {
    let at = e.span().map(|s| {
        let before = &text[..s.start.min(text.len())];
        let line = before.matches('\n').count() + 1;
        let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
        format!("line {line}, column {column}: ")
    });
    format!("{}{}", at.unwrap_or_default(), one_line(e.message()))
}

#[cfg(test)]
mod tests {
    use super::*;

    const PROGRAM: &str = r#"
[procedure]
runs = 2
captures = 3
overshoot_mm = 5.0
fps = 100.0
feed_mm_per_s = 20.0
settle_s = 0.3

[[procedure.axes]]
axis = "X"
start_mm = -10.0
length_mm = 20.0
segments = 2
lines_mm = [0.0]
"#;

    #[test]
    fn a_program_reads_and_other_tables_are_ignored() {
        let text = format!("seed = 3\n[sensor]\nwidth = 10\n{PROGRAM}");
        let p = parse_program(&text, Path::new("p.toml")).unwrap();
        assert_eq!((p.runs, p.captures), (2, 3));
        assert_eq!(p.dwells().len(), 3 * 2 * 2);
    }

    #[test]
    fn missing_and_unknown_keys_are_named() {
        let e = parse_program(&PROGRAM.replace("captures = 3\n", ""), Path::new("p.toml"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("p.toml") && e.contains("procedure.captures"),
            "{e}"
        );
        let e = parse_program(&PROGRAM.replace("segments = 2\n", ""), Path::new("p.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("procedure.axes[0].segments"), "{e}");
        let e = parse_program(&format!("{PROGRAM}\nfsp = 3\n"), Path::new("p.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("fsp"), "{e}");
        let e = parse_program(
            &PROGRAM.replace("fps = 100.0", "fps = 0.0"),
            Path::new("p.toml"),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("procedure.fps"), "{e}");
        let e = parse_program("[procedure\n", Path::new("p.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 1"), "{e}");
    }
}
