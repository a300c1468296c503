//! What an interrupted process must remove: every temporary file, staging
//! folder and output lock that exists while the process runs is listed here
//! from the moment it is created until it is renamed into place or removed.
//! The binary's SIGINT/SIGTERM handler calls [`clean_up_then`]; libraries
//! never install handlers.
//!
//! The list is process-wide (a signal ends the whole process, whichever
//! thread created the file). A file is created while the list is locked, so
//! an interruption never falls between its creation and its listing.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard, PoisonError};

/// What a listed path is, and so how it is removed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    /// A temporary file (removed).
    File,
    /// A staging folder (removed with its content).
    Folder,
}

static LIVE: Mutex<BTreeMap<u64, (PathBuf, Kind)>> = Mutex::new(BTreeMap::new());
static NEXT: AtomicU64 = AtomicU64::new(0);

fn live() -> MutexGuard<'static, BTreeMap<u64, (PathBuf, Kind)>> {
    // A panic while the list was locked leaves it consistent (inserts and
    // removals are single operations): keep using it.
    LIVE.lock().unwrap_or_else(PoisonError::into_inner)
}

/// A listed path; dropping it takes the path off the list (it was renamed
/// into place or removed by its owner).
#[derive(Debug)]
pub(crate) struct Listed(u64);

impl Drop for Listed {
    fn drop(&mut self) {
        live().remove(&self.0);
    }
}

/// Create something with `create` (which returns it and its path) and list
/// the path, both while the list is locked.
pub(crate) fn create_listed<T>(
    kind: Kind,
    create: impl FnOnce() -> std::io::Result<(T, PathBuf)>,
) -> std::io::Result<(T, Listed)> {
    let mut list = live();
    let (value, path) = create()?;
    let id = NEXT.fetch_add(1, Ordering::Relaxed);
    list.insert(id, (path, kind));
    Ok((value, Listed(id)))
}

/// Remove every listed path, then call `then` with their number while the
/// list stays locked — so that no other thread creates or renames a listed
/// file meanwhile. `then` is where the binary ends the process.
pub fn clean_up_then<R>(then: impl FnOnce(usize) -> R) -> R {
    let list = live();
    let mut removed = 0;
    for (path, kind) in list.values() {
        if remove(path, *kind) {
            removed += 1;
        }
    }
    then(removed)
}

fn remove(path: &Path, kind: Kind) -> bool {
    match kind {
        Kind::File => std::fs::remove_file(path).is_ok(),
        Kind::Folder => std::fs::remove_dir_all(path).is_ok(),
    }
}

/// A scratch folder in the system's temporary folder, removed when dropped
/// and when the process is interrupted.
#[derive(Debug)]
pub struct ScratchFolder {
    temp: tempfile::TempDir,
    _listed: Listed,
}

impl ScratchFolder {
    /// A fresh scratch folder.
    pub fn new() -> std::io::Result<Self> {
        let (temp, listed) = create_listed(Kind::Folder, || {
            let temp = tempfile::Builder::new().prefix("trinocular-").tempdir()?;
            let path = temp.path().to_path_buf();
            Ok((temp, path))
        })?;
        Ok(Self {
            temp,
            _listed: listed,
        })
    }

    /// Its path.
    pub fn path(&self) -> &Path {
        self.temp.path()
    }
}

/// The paths listed now (for tests).
#[cfg(test)]
pub(crate) fn listed() -> Vec<PathBuf> {
    live().values().map(|(p, _)| p.clone()).collect()
}
