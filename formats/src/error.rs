//! The one error type of `formats`: every message names the file, and where
//! it applies the row (1-based line number in the file) and the column.

use std::path::PathBuf;

use thiserror::Error;

/// A file could not be read or written, or its content breaks the contract.
#[derive(Debug, Error)]
pub enum FormatError {
    /// Operating-system error on a file.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A CSV row or field is malformed or invalid.
    #[error("{}: line {line}{}: {message}", path.display(), column.as_ref().map(|c| format!(", column '{c}'")).unwrap_or_default())]
    Row {
        /// The file.
        path: PathBuf,
        /// 1-based line number in the file (the header is line 1).
        line: u64,
        /// Column name, when one column is at fault.
        column: Option<String>,
        /// What is wrong.
        message: String,
    },
    /// An output exists and the command was not told to replace it.
    #[error("{}: already exists; give --force to replace it or choose another --out", path.display())]
    Exists {
        /// The output.
        path: PathBuf,
    },
    /// An output would be written over one of the command's inputs (the same
    /// file, also through a link, or a folder holding it).
    #[error("{}: would overwrite an input of this run{}; choose another --out", output.display(), if input == output { String::new() } else { format!(" ({})", input.display()) })]
    OverwritesInput {
        /// The output.
        output: PathBuf,
        /// The input, as given.
        input: PathBuf,
    },
    /// Another run holds the lock of an output folder.
    #[error("{}: another trinocular run ({holder}) is writing into this folder; wait for it to finish or choose another --out", folder.display())]
    Locked {
        /// The output folder.
        folder: PathBuf,
        /// Who holds the lock, as its lock file says (`pid N, COMMAND`).
        holder: String,
    },
    /// The file as a whole is malformed (empty, missing columns, bad JSON).
    #[error("{}: {message}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

impl FormatError {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }

    /// A whole-file error on `path`.
    pub fn file(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Self::File {
            path: path.into(),
            message: message.into(),
        }
    }
}

/// Result alias for `formats`.
pub type Result<T> = std::result::Result<T, FormatError>;
