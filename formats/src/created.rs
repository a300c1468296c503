//! What this run created: the output folders it made, the files it put in
//! place where none was, the report sets it put in place where none was —
//! so that a run that fails removes exactly that ([`discard`]) and never a
//! file or folder that existed before it (docs/formats.md, "How outputs are written": a failure
//! leaves the output location as it was).
//!
//! The record is process-wide, as [`crate::interrupt`]'s list is: a run is
//! the process, whichever plan or thread wrote the file. The binary calls
//! [`discard`] when a command fails; an interrupted run keeps what it put in
//! place (`measure` resumes from it).

use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, PoisonError};

use crate::{FormatError, Result};

/// What a created path is, and so how it is removed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// A file put in place (removed).
    File,
    /// A set folder put in place whole (removed with its content).
    Set,
    /// A folder made empty (removed only if empty again: a file that is not
    /// the run's keeps it).
    Folder,
}

static CREATED: Mutex<Vec<(PathBuf, Kind)>> = Mutex::new(Vec::new());

fn created() -> MutexGuard<'static, Vec<(PathBuf, Kind)>> {
    // Pushes are single operations: a panic elsewhere leaves the list whole.
    CREATED.lock().unwrap_or_else(PoisonError::into_inner)
}

/// A file this run put in place where none was.
pub(crate) fn file(path: &Path) {
    created().push((path.to_path_buf(), Kind::File));
}

/// A set folder this run put in place where none was.
pub(crate) fn set(path: &Path) {
    created().push((path.to_path_buf(), Kind::Set));
}

/// Make `folder` and the folders above it that are missing, recording each
/// one made. A file where a folder is needed is named as such.
pub(crate) fn make_folders(folder: &Path) -> Result<()> {
    let missing = missing_folders(folder)?;
    for f in missing.iter().rev() {
        match std::fs::create_dir(f) {
            Ok(()) => created().push((f.clone(), Kind::Folder)),
            // Made meanwhile by another process: not ours.
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && f.is_dir() => {}
            Err(e) => return Err(FormatError::io(f, e)),
        }
    }
    Ok(())
}

/// The folders of `folder`'s path that do not exist, deepest first; an
/// error when the nearest that exists is not a folder.
pub(crate) fn missing_folders(folder: &Path) -> Result<Vec<PathBuf>> {
    let mut missing = Vec::new();
    let mut at = folder;
    loop {
        if at.as_os_str().is_empty() {
            // A relative path's top: the current folder.
            return Ok(missing);
        }
        match at.symlink_metadata() {
            Ok(_) if at.is_dir() => return Ok(missing),
            Ok(_) => {
                return Err(FormatError::file(
                    at,
                    "is a file, not a folder; choose another --out",
                ));
            }
            Err(_) => missing.push(at.to_path_buf()),
        }
        match at.parent() {
            Some(parent) => at = parent,
            None => return Ok(missing),
        }
    }
}

/// Remove everything this run created, newest first, and forget it; the
/// paths that could not be removed, with the reason. Folders are removed
/// only when empty: one that holds a file the run did not write stays.
pub fn discard() -> Vec<(PathBuf, std::io::Error)> {
    let list = std::mem::take(&mut *created());
    let mut kept = Vec::new();
    for (path, kind) in list.iter().rev() {
        let removed = match kind {
            Kind::File => std::fs::remove_file(path),
            Kind::Set => std::fs::remove_dir_all(path),
            Kind::Folder => std::fs::remove_dir(path),
        };
        match removed {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => kept.push((path.clone(), e)),
        }
    }
    kept
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    #[test]
    fn the_missing_folders_are_named_deepest_first() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        assert!(missing_folders(d).unwrap().is_empty());
        assert_eq!(
            missing_folders(&d.join("a/b")).unwrap(),
            [d.join("a/b"), d.join("a")]
        );
        std::fs::write(d.join("f"), "").unwrap();
        let e = missing_folders(&d.join("f/b")).unwrap_err().to_string();
        assert!(e.contains("is a file, not a folder"), "{e}");
        assert!(missing_folders(Path::new("no-such-folder-here")).is_ok());
    }
}
