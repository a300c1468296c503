//! The lock of an output folder: `.trinocular.lock` in it, holding the pid
//! and command of the run that writes there, and locked with the operating
//! system's advisory file lock (`File::try_lock`). A second run is refused
//! with the holder's pid; a lock file whose process died (killed, machine
//! crash) is not locked by anyone, so the next run takes it over and says so.
//! One lock per folder, not per output: a second run into a folder in use is
//! refused whatever its `--out`, and one lock file says who writes there.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use crate::interrupt::{Kind, Listed, create_listed};
use crate::{FormatError, Result};

/// Name of the lock file in an output folder.
pub const LOCK_FILE: &str = ".trinocular.lock";

/// Attempts at taking a lock whose file another process removes meanwhile.
const ATTEMPTS: usize = 8;

/// A held lock; released (and its file removed) when dropped, and its file
/// removed when the process is interrupted ([`crate::interrupt`]).
#[derive(Debug)]
pub struct OutputLock {
    path: PathBuf,
    file: File,
    _listed: Listed,
}

/// A lock just taken.
#[derive(Debug)]
pub struct Acquired {
    /// The lock.
    pub lock: OutputLock,
    /// The holder written in a lock file that nobody held: a run that died
    /// without removing it.
    pub stale: Option<String>,
}

impl OutputLock {
    /// Lock `folder` (which must exist) for `command`.
    pub fn acquire(folder: &Path, command: &str) -> Result<Acquired> {
        let path = folder.join(LOCK_FILE);
        let io = |e: std::io::Error| FormatError::io(&path, e);
        if !folder.is_dir() {
            return Err(FormatError::file(folder, "output folder does not exist"));
        }
        for _ in 0..ATTEMPTS {
            let file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&path)
                .map_err(io)?;
            match file.try_lock() {
                Ok(()) => {}
                Err(TryLockError::WouldBlock) => {
                    return Err(FormatError::Locked {
                        folder: folder.to_path_buf(),
                        holder: holder(&file).unwrap_or_else(|| "unknown process".into()),
                    });
                }
                Err(TryLockError::Error(e)) => return Err(io(e)),
            }
            // The holder before us may have removed the file between our open
            // and our lock: then our lock is on a file nobody else will see.
            if !same_file(&file, &path) {
                continue;
            }
            // Ours from here on: removed if the process is interrupted.
            let ((), listed) = create_listed(Kind::File, || Ok(((), path.clone()))).map_err(io)?;
            let stale = holder(&file);
            let mut lock = Self {
                path: path.clone(),
                file,
                _listed: listed,
            };
            lock.write_holder(command).map_err(io)?;
            return Ok(Acquired { lock, stale });
        }
        Err(FormatError::file(
            &path,
            "the lock file keeps changing; another run is starting here",
        ))
    }

    fn write_holder(&mut self, command: &str) -> std::io::Result<()> {
        self.file.set_len(0)?;
        self.file.seek(SeekFrom::Start(0))?;
        writeln!(
            self.file,
            "pid {}, trinocular {command}",
            std::process::id()
        )?;
        self.file.sync_all()
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        // Remove while still holding the lock; closing the file releases it.
        let _ = std::fs::remove_file(&self.path);
    }
}

/// The holder a lock file names (its first line), if any.
fn holder(mut file: &File) -> Option<String> {
    let mut text = String::new();
    file.seek(SeekFrom::Start(0)).ok()?;
    file.take(256).read_to_string(&mut text).ok()?;
    let line = text.lines().next()?.trim();
    (!line.is_empty()).then(|| line.to_string())
}

/// Whether the open `file` is still the file at `path`.
fn same_file(file: &File, path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (file.metadata(), std::fs::metadata(path)) {
            (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        let _ = file;
        path.exists()
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    #[test]
    fn a_second_lock_is_refused_with_the_holder() {
        let dir = tempfile::tempdir().unwrap();
        let first = OutputLock::acquire(dir.path(), "measure").unwrap();
        assert!(first.stale.is_none());
        let text = std::fs::read_to_string(dir.path().join(LOCK_FILE)).unwrap();
        assert_eq!(
            text,
            format!("pid {}, trinocular measure\n", std::process::id())
        );
        let e = OutputLock::acquire(dir.path(), "extract").unwrap_err();
        assert!(
            matches!(&e, FormatError::Locked { holder, .. } if holder == text.trim()),
            "{e}"
        );
        assert!(
            dir.path().join(LOCK_FILE).exists(),
            "the holder's file stays"
        );
        drop(first);
        assert!(!dir.path().join(LOCK_FILE).exists());
        let again = OutputLock::acquire(dir.path(), "extract").unwrap();
        assert!(again.stale.is_none());
    }

    #[test]
    fn a_dead_runs_lock_is_taken_over() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join(LOCK_FILE),
            "pid 999999, trinocular measure\n",
        )
        .unwrap();
        let taken = OutputLock::acquire(dir.path(), "measure").unwrap();
        assert_eq!(
            taken.stale.as_deref(),
            Some("pid 999999, trinocular measure")
        );
    }

    #[test]
    fn a_missing_folder_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let e = OutputLock::acquire(&dir.path().join("nope"), "extract")
            .unwrap_err()
            .to_string();
        assert!(e.contains("nope: output folder does not exist"), "{e}");
    }
}
