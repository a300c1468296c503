//! NIST StRD / algorithm-testing point files (`.ds`): a first line holding
//! the number of points, then one point per line, three coordinates
//! separated by tabs or spaces (`testdata/nist-fits/README.md`).

use std::path::Path;

use geom::Point3;

use crate::{FormatError, Result};

/// Read a `.ds` file. Blank lines are skipped; errors name the file and the
/// 1-based line. The announced count is checked against the points the file
/// holds, never used to size a buffer (a header may announce 10¹⁹ points).
pub fn read_ds(path: &Path) -> Result<Vec<Point3<f64>>> {
    let text = std::fs::read_to_string(path).map_err(|e| FormatError::io(path, e))?;
    parse_ds(&text, path)
}

/// Parse the text of a `.ds` file read from `path` (named in errors).
pub(crate) fn parse_ds(text: &str, path: &Path) -> Result<Vec<Point3<f64>>> {
    let row = |line: usize, message: String| FormatError::Row {
        path: path.into(),
        line: line as u64 + 1,
        column: None,
        message,
    };
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (i, first) = lines
        .next()
        .ok_or_else(|| FormatError::file(path, "the file is empty"))?;
    let n: usize = first
        .trim()
        .parse()
        .map_err(|e| row(i, format!("expected the number of points: {e}")))?;
    let mut points = Vec::new();
    for (i, line) in lines {
        let v: Vec<f64> = line
            .split_whitespace()
            .map(str::parse)
            .collect::<std::result::Result<_, _>>()
            .map_err(|e| row(i, format!("not a number: {e}")))?;
        if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
            return Err(row(i, "expected three finite coordinates".into()));
        }
        points.push(Point3::new(v[0], v[1], v[2]));
    }
    if points.len() != n {
        return Err(FormatError::file(
            path,
            format!(
                "header announces {n} points but the file holds {}",
                points.len()
            ),
        ));
    }
    Ok(points)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_and_errors() {
        let p = Path::new("a.ds");
        let pts = parse_ds("2\n1\t2\t3\n\n 4 5\t6e-1\n", p).unwrap();
        assert_eq!(
            pts,
            vec![Point3::new(1.0, 2.0, 3.0), Point3::new(4.0, 5.0, 0.6)]
        );
        let e = parse_ds("3\n1\t2\t3\n", p).unwrap_err().to_string();
        assert_eq!(e, "a.ds: header announces 3 points but the file holds 1");
        let e = parse_ds("1\n1\t2\n", p).unwrap_err().to_string();
        assert_eq!(e, "a.ds: line 2: expected three finite coordinates");
        let e = parse_ds("1\n1\tx\t3\n", p).unwrap_err().to_string();
        assert!(e.starts_with("a.ds: line 2: not a number"), "{e}");
        let e = parse_ds("many\n", p).unwrap_err().to_string();
        assert!(
            e.starts_with("a.ds: line 1: expected the number of points"),
            "{e}"
        );
        assert_eq!(
            parse_ds("\n", p).unwrap_err().to_string(),
            "a.ds: the file is empty"
        );
        let huge = parse_ds("18446744073709551615\n1 2 3\n", p)
            .unwrap_err()
            .to_string();
        assert!(huge.contains("18446744073709551615 points") && huge.contains("holds 1"));
    }
}
