//! Reading and writing CSV tables of typed records, with errors that name the
//! file, the line and the column.

use std::io::Read;
use std::path::Path;

use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::atomic::AtomicFile;
use crate::{FormatError, Result};

/// A CSV record of the file contract.
pub trait Record: DeserializeOwned + Serialize {
    /// Columns that must be present in the header.
    const COLUMNS: &'static [&'static str];
    /// Columns that follow them and may be absent on reading (newer
    /// additions); the header of a file without records lists both.
    const OPTIONAL_COLUMNS: &'static [&'static str] = &[];
    /// Check the values of one row; on failure give the column at fault and why.
    fn validate(&self) -> std::result::Result<(), Invalid>;
}

/// A value that breaks the contract: its column and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct Invalid {
    /// Column name.
    pub column: &'static str,
    /// What is wrong.
    pub message: String,
}

impl Invalid {
    /// A new complaint about `column`.
    pub fn new(column: &'static str, message: impl Into<String>) -> Self {
        Self {
            column,
            message: message.into(),
        }
    }
}

/// Fails unless `value` is finite (rejects NaN and ±inf).
pub fn finite(column: &'static str, value: f64) -> std::result::Result<(), Invalid> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(Invalid::new(
            column,
            format!("value {value} is not a finite number"),
        ))
    }
}

/// Fails unless an optional standard uncertainty is finite and ≥ 0.
pub fn standard_uncertainty(
    column: &'static str,
    value: Option<f64>,
) -> std::result::Result<(), Invalid> {
    match value {
        Some(u) if !(u.is_finite() && u >= 0.0) => Err(Invalid::new(
            column,
            format!("standard uncertainty {u} is not a finite number ≥ 0"),
        )),
        _ => Ok(()),
    }
}

/// A record and the line it came from (1-based; the header is line 1).
#[derive(Debug, Clone, PartialEq)]
pub struct Row<T> {
    /// Line number in the file.
    pub line: u64,
    /// The record.
    pub record: T,
}

/// Read every record of a CSV file, checking the header and each row.
pub fn read_csv<T: Record>(path: &Path) -> Result<Vec<Row<T>>> {
    let file = std::fs::File::open(path).map_err(|e| FormatError::io(path, e))?;
    read_csv_from(file, path)
}

/// Line numbers of byte offsets in a text whose lines end in `\n`, `\r\n`
/// or `\r`. The `csv` crate's own line count lags by one after every `\r\n`
/// (it ends a record at the `\r` and counts the `\n` into the next one) and
/// ignores lone `\r`, so lines are counted here from the bytes.
struct Lines<'a> {
    bytes: &'a [u8],
    /// Offsets where the second and later lines begin, ascending.
    starts: Vec<usize>,
}

impl<'a> Lines<'a> {
    fn new(bytes: &'a [u8]) -> Self {
        let starts = (0..bytes.len())
            .filter(|&i| match bytes[i] {
                b'\n' => true,
                b'\r' => bytes.get(i + 1) != Some(&b'\n'),
                _ => false,
            })
            .map(|i| i + 1)
            .collect();
        Self { bytes, starts }
    }

    /// 1-based line of the record that starts at `offset` (line ends left
    /// over from the previous record are skipped).
    fn line_of(&self, offset: u64) -> u64 {
        let mut at = usize::try_from(offset)
            .unwrap_or(usize::MAX)
            .min(self.bytes.len());
        while at < self.bytes.len() && matches!(self.bytes[at], b'\r' | b'\n') {
            at += 1;
        }
        self.starts.partition_point(|&s| s <= at) as u64 + 1
    }
}

/// As [`read_csv`], from any reader; `path` names the source in errors.
pub fn read_csv_from<T: Record, R: Read>(mut reader: R, path: &Path) -> Result<Vec<Row<T>>> {
    let mut bytes = Vec::new();
    reader
        .read_to_end(&mut bytes)
        .map_err(|e| FormatError::io(path, e))?;
    let lines = Lines::new(&bytes);
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(bytes.as_slice());
    let headers = rdr
        .headers()
        .map_err(|e| csv_error(path, e, None, &lines))?
        .clone();
    if headers.is_empty() || headers.iter().all(str::is_empty) {
        return Err(FormatError::file(path, "the file is empty (no header row)"));
    }
    for column in T::COLUMNS {
        if !headers.iter().any(|h| h == *column) {
            return Err(FormatError::Row {
                path: path.to_path_buf(),
                line: 1,
                column: Some((*column).to_string()),
                message: "required column is missing from the header".into(),
            });
        }
    }
    let mut rows = Vec::new();
    for result in rdr.records() {
        let raw = result.map_err(|e| csv_error(path, e, Some(&headers), &lines))?;
        let line = raw.position().map_or(0, |p| lines.line_of(p.byte()));
        let record: T = raw
            .deserialize(Some(&headers))
            .map_err(|e| csv_error(path, e, Some(&headers), &lines))
            .map_err(|e| with_line(e, line))?;
        record.validate().map_err(|inv| FormatError::Row {
            path: path.to_path_buf(),
            line,
            column: Some(inv.column.to_string()),
            message: inv.message,
        })?;
        rows.push(Row { line, record });
    }
    Ok(rows)
}

/// Put the record's line into a row error that lacks one.
fn with_line(e: FormatError, line: u64) -> FormatError {
    match e {
        FormatError::Row {
            path,
            line: 0,
            column,
            message,
        } => FormatError::Row {
            path,
            line,
            column,
            message,
        },
        other => other,
    }
}

fn csv_error(
    path: &Path,
    e: csv::Error,
    headers: Option<&csv::StringRecord>,
    lines: &Lines<'_>,
) -> FormatError {
    let line = e.position().map_or(0, |p| lines.line_of(p.byte()));
    match e.into_kind() {
        csv::ErrorKind::Io(source) => FormatError::io(path, source),
        csv::ErrorKind::Deserialize { err, .. } => FormatError::Row {
            path: path.to_path_buf(),
            line,
            column: err
                .field()
                .and_then(|f| headers.and_then(|h| h.get(f as usize)))
                .map(str::to_string),
            message: err.kind().to_string(),
        },
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => FormatError::Row {
            path: path.to_path_buf(),
            line,
            column: None,
            message: format!("{len} fields where the header has {expected_len}"),
        },
        csv::ErrorKind::Utf8 { err, .. } => FormatError::Row {
            path: path.to_path_buf(),
            line,
            column: None,
            message: format!("not UTF-8: {err}"),
        },
        other => FormatError::file(path, format!("{other:?}")),
    }
}

/// Write records as CSV (header from the record's field names), atomically,
/// replacing an existing file (commands write their outputs through an
/// [`crate::OutputPlan`]).
pub fn write_csv<'a, T: Serialize + 'a>(
    path: &Path,
    records: impl IntoIterator<Item = &'a T>,
) -> Result<()> {
    write_csv_into(AtomicFile::create(path)?, records)
}

/// [`write_csv`] into an atomic file, committed at the end.
pub(crate) fn write_csv_into<'a, T: Serialize + 'a>(
    file: AtomicFile,
    records: impl IntoIterator<Item = &'a T>,
) -> Result<()> {
    let path = file.target().to_path_buf();
    serialize_all(csv::Writer::from_writer(file), records, &path)
}

/// Serialise every record into `w`, then commit its atomic file.
fn serialize_all<'a, T: Serialize + 'a>(
    mut w: csv::Writer<AtomicFile>,
    records: impl IntoIterator<Item = &'a T>,
    path: &Path,
) -> Result<()> {
    for r in records {
        w.serialize(r)
            .map_err(|e| FormatError::file(path, e.to_string()))?;
    }
    let file = w
        .into_inner()
        .map_err(|e| FormatError::io(path, e.into_error()))?;
    file.commit()
}

/// Write records of the contract as CSV, atomically, replacing an existing
/// file; the header is written even when there are no records (from
/// [`Record::COLUMNS`] and [`Record::OPTIONAL_COLUMNS`], which must then
/// list every field in order).
pub fn write_records<'a, T: Record + 'a>(
    path: &Path,
    records: impl IntoIterator<Item = &'a T>,
) -> Result<()> {
    write_records_into(AtomicFile::create(path)?, records)
}

/// [`write_records`] into an atomic file, committed at the end.
pub(crate) fn write_records_into<'a, T: Record + 'a>(
    file: AtomicFile,
    records: impl IntoIterator<Item = &'a T>,
) -> Result<()> {
    let path = file.target().to_path_buf();
    let path = path.as_path();
    let mut w = csv::WriterBuilder::new()
        .has_headers(false)
        .from_writer(file);
    let mut records = records.into_iter().peekable();
    let header: Vec<String> = match records.peek() {
        Some(first) => {
            let mut probe = csv::Writer::from_writer(Vec::new());
            probe
                .serialize(first)
                .map_err(|e| FormatError::file(path, e.to_string()))?;
            let bytes = probe
                .into_inner()
                .map_err(|e| FormatError::file(path, e.to_string()))?;
            let text = String::from_utf8_lossy(&bytes).into_owned();
            text.lines()
                .next()
                .unwrap_or_default()
                .split(',')
                .map(str::to_string)
                .collect()
        }
        None => T::COLUMNS
            .iter()
            .chain(T::OPTIONAL_COLUMNS)
            .map(|c| (*c).to_string())
            .collect(),
    };
    w.write_record(&header)
        .map_err(|e| FormatError::file(path, e.to_string()))?;
    serialize_all(w, records, path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, Serialize, Deserialize, PartialEq)]
    struct P {
        name: String,
        x: f64,
    }
    impl Record for P {
        const COLUMNS: &'static [&'static str] = &["name", "x"];
        fn validate(&self) -> std::result::Result<(), Invalid> {
            finite("x", self.x)
        }
    }

    fn read(text: &str) -> Result<Vec<Row<P>>> {
        read_csv_from(text.as_bytes(), Path::new("p.csv"))
    }

    #[test]
    fn good_file_reads_with_line_numbers() {
        let rows = read("name,x\na,1.5\nb, 2\n").unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[1].line, 3);
        assert_eq!(rows[1].record.x, 2.0);
    }

    #[test]
    fn errors_name_line_and_column() {
        let e = read("name,x\na,1\nb,NaN\n").unwrap_err().to_string();
        assert!(e.contains("p.csv: line 3, column 'x'"), "{e}");
        let e = read("name,x\na,1\nb,abc\n").unwrap_err().to_string();
        assert!(e.contains("line 3, column 'x'"), "{e}");
        let e = read("name,y\na,1\n").unwrap_err().to_string();
        assert!(e.contains("column 'x'") && e.contains("missing"), "{e}");
        let e = read("").unwrap_err().to_string();
        assert!(e.contains("empty"), "{e}");
        let e = read("name,x\na,1,2\n").unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("fields"), "{e}");
    }

    #[test]
    fn lines_are_counted_the_same_with_crlf_line_ends() {
        for end in ["\n", "\r\n", "\r"] {
            let text = ["name,x", "a,1", "", "b,2", "c,NaN", ""].join(end);
            let e = read(&text).unwrap_err().to_string();
            assert!(e.contains("p.csv: line 5, column 'x'"), "{end:?}: {e}");
            let text = ["name,x", "a,1", "b,2"].join(end);
            let rows = read(&text).unwrap();
            assert_eq!([rows[0].line, rows[1].line], [2, 3], "{end:?}");
            let text = ["name,x", "a,1", "b,2,3"].join(end);
            let e = read(&text).unwrap_err().to_string();
            assert!(e.contains("line 3:"), "{end:?}: {e}");
        }
    }

    #[test]
    fn records_keep_their_header_when_empty() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.csv");
        write_records::<P>(&path, &[]).unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "name,x\n");
        write_records(
            &path,
            &[P {
                name: "a".into(),
                x: 1.5,
            }],
        )
        .unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "name,x\na,1.5\n");
    }

    #[test]
    fn write_then_read_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.csv");
        let data = vec![
            P {
                name: "a".into(),
                x: 0.1,
            },
            P {
                name: "b".into(),
                x: -3e-9,
            },
        ];
        write_csv(&path, &data).unwrap();
        let back: Vec<P> = read_csv(&path)
            .unwrap()
            .into_iter()
            .map(|r| r.record)
            .collect();
        assert_eq!(back, data);
    }
}
