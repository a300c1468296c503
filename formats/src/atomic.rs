//! Atomic output: write to a temporary file beside the target (a unique name,
//! `.NAME.XXXXXX.tmp`, from the `tempfile` crate), sync it, rename it into
//! place and sync the folder, so a reader never sees a half-written file and
//! a crash never truncates an existing one. The temporary file is removed
//! when the writer is dropped without commit and, through
//! [`crate::interrupt`], when the process is interrupted; a file put in place
//! where none was is recorded as the run's ([`crate::created`]).

use std::fs::{File, Permissions};
use std::io::{BufWriter, ErrorKind, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use tempfile::NamedTempFile;

use crate::interrupt::{Kind, Listed, create_listed};
use crate::{FormatError, Result};

/// Random characters in a temporary name (`tempfile`'s alphabet: ASCII letters and digits).
pub(crate) const TEMP_RANDOM: usize = 6;
/// Suffix of every temporary file and staging folder.
pub(crate) const TEMP_SUFFIX: &str = ".tmp";

/// The prefix of the temporary names of `target` (`.NAME.`).
pub(crate) fn temp_prefix(target: &Path) -> Result<String> {
    let name = target
        .file_name()
        .ok_or_else(|| FormatError::file(target, "not a file path"))?;
    Ok(format!(".{}.", name.to_string_lossy()))
}

/// Whether `name` is a temporary name of the file or folder named `target_name`.
pub(crate) fn is_temp_name(name: &str, target_name: &str) -> bool {
    name.strip_prefix('.')
        .and_then(|n| n.strip_prefix(target_name))
        .and_then(|n| n.strip_prefix('.'))
        .and_then(|n| n.strip_suffix(TEMP_SUFFIX))
        .is_some_and(|r| r.len() == TEMP_RANDOM && r.bytes().all(|b| b.is_ascii_alphanumeric()))
}

/// How every temporary file and folder is made: `<prefix>` + random
/// characters + [`TEMP_SUFFIX`], with the permissions of a new `folder` or file.
pub(crate) fn temp_builder(prefix: &str, folder: bool) -> tempfile::Builder<'_, 'static> {
    let mut builder = tempfile::Builder::new();
    builder
        .prefix(prefix)
        .suffix(TEMP_SUFFIX)
        .rand_bytes(TEMP_RANDOM);
    #[cfg(unix)]
    builder.permissions(new_permissions(folder));
    #[cfg(not(unix))]
    let _ = folder;
    builder
}

/// The folder of `path` (`.` for a bare name).
pub fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// A file next to `path` named `<stem><suffix>`, the stem being `path`'s
/// file name without its extension (`rig.json`, `.residuals.csv` →
/// `rig.residuals.csv`); `default_stem` when `path` has no file name. The
/// rule that names every sidecar of an output (docs/formats.md, Sidecars).
pub fn beside(path: &Path, default_stem: &str, suffix: &str) -> PathBuf {
    let stem = path
        .file_stem()
        .map_or_else(|| default_stem.into(), |s| s.to_string_lossy().into_owned());
    path.with_file_name(format!("{stem}{suffix}"))
}

/// Permissions asked for new files and folders: everyone may read (and
/// write) as the umask allows, as for any file a program creates —
/// `tempfile`'s own default (owner only) would carry over to the outputs.
#[cfg(unix)]
pub(crate) fn new_permissions(folder: bool) -> Permissions {
    use std::os::unix::fs::PermissionsExt;
    Permissions::from_mode(if folder { 0o777 } else { 0o666 })
}

/// The error of creating a temporary file or folder for `target` in `folder`.
pub(crate) fn create_error(target: &Path, folder: &Path, e: std::io::Error) -> FormatError {
    if e.kind() == ErrorKind::NotFound && !folder.is_dir() {
        FormatError::file(
            target,
            format!("output folder {} does not exist", folder.display()),
        )
    } else {
        FormatError::io(target, e)
    }
}

/// Sync a folder after a rename in it, so that the new name survives a crash
/// (a no-op where folders cannot be opened for syncing).
pub(crate) fn sync_folder(folder: &Path) -> Result<()> {
    #[cfg(unix)]
    {
        File::open(folder)
            .and_then(|f| f.sync_all())
            .map_err(|e| FormatError::io(folder, e))?;
    }
    #[cfg(not(unix))]
    let _ = folder;
    Ok(())
}

/// A file being written; it appears under its final name only on [`AtomicFile::commit`].
/// Dropped without commit, the temporary file is removed.
#[derive(Debug)]
pub struct AtomicFile {
    target: PathBuf,
    writer: Option<BufWriter<NamedTempFile>>,
    replace: bool,
    _listed: Listed,
}

impl AtomicFile {
    /// Start writing `target` (its folder must exist); commit replaces an
    /// existing file.
    pub fn create(target: impl AsRef<Path>) -> Result<Self> {
        Self::open(target.as_ref(), true)
    }

    /// Start writing `target`; commit fails with [`FormatError::Exists`]
    /// when a file of that name exists by then (created since the command
    /// checked its outputs).
    pub fn create_new(target: impl AsRef<Path>) -> Result<Self> {
        Self::open(target.as_ref(), false)
    }

    fn open(target: &Path, replace: bool) -> Result<Self> {
        let prefix = temp_prefix(target)?;
        let folder = folder_of(target);
        let (temp, listed) = create_listed(Kind::File, || {
            let temp = temp_builder(&prefix, false).tempfile_in(folder)?;
            let path = temp.path().to_path_buf();
            Ok((temp, path))
        })
        .map_err(|e| create_error(target, folder, e))?;
        Ok(Self {
            target: target.to_path_buf(),
            writer: Some(BufWriter::new(temp)),
            replace,
            _listed: listed,
        })
    }

    /// The final path.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Flush, sync, rename into place and sync the folder.
    pub fn commit(mut self) -> Result<()> {
        let Some(writer) = self.writer.take() else {
            return Err(FormatError::file(
                &self.target,
                "atomic file already committed",
            ));
        };
        let temp = writer
            .into_inner()
            .map_err(|e| FormatError::io(&self.target, e.into_error()))?;
        temp.as_file()
            .sync_all()
            .map_err(|e| FormatError::io(&self.target, e))?;
        let existed = self.target.symlink_metadata().is_ok();
        let persisted = if self.replace {
            temp.persist(&self.target)
        } else {
            temp.persist_noclobber(&self.target)
        };
        match persisted {
            Ok(_) => {
                if !existed {
                    crate::created::file(&self.target);
                }
                sync_folder(folder_of(&self.target))
            }
            Err(e) if e.error.kind() == ErrorKind::AlreadyExists => Err(FormatError::Exists {
                path: self.target.clone(),
            }),
            Err(e) => Err(FormatError::io(&self.target, e.error)),
        }
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self.writer.as_mut() {
            Some(w) => w.write(buf),
            None => Err(std::io::Error::other("atomic file already committed")),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        match self.writer.as_mut() {
            Some(w) => w.flush(),
            None => Ok(()),
        }
    }
}

/// Seeking flushes the buffer; encoders that patch offsets (TIFF) can write
/// straight into the temporary file.
impl Seek for AtomicFile {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        match self.writer.as_mut() {
            Some(w) => w.seek(pos),
            None => Err(std::io::Error::other("atomic file already committed")),
        }
    }
}

/// Write `bytes` into `file` and commit it.
pub(crate) fn write_into(mut file: AtomicFile, bytes: &[u8]) -> Result<()> {
    file.write_all(bytes)
        .map_err(|e| FormatError::io(file.target().to_path_buf(), e))?;
    file.commit()
}

/// Write `bytes` to `target` atomically, replacing an existing file
/// (commands write their outputs through an [`crate::OutputPlan`]).
pub fn write_atomic(target: impl AsRef<Path>, bytes: &[u8]) -> Result<()> {
    write_into(AtomicFile::create(target)?, bytes)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    #[test]
    fn beside_names_a_sibling_after_the_stem() {
        assert_eq!(
            beside(Path::new("out/rig.json"), "rig", ".cam1.opencv.yml"),
            Path::new("out/rig.cam1.opencv.yml")
        );
        assert_eq!(beside(Path::new("a"), "rig", ".csv"), Path::new("a.csv"));
    }

    #[test]
    fn uncommitted_file_leaves_target_untouched() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.csv");
        write_atomic(&target, b"old").unwrap();
        {
            let mut f = AtomicFile::create(&target).unwrap();
            f.write_all(b"new, half written").unwrap();
            // dropped without commit
        }
        assert_eq!(std::fs::read(&target).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        let mut f = AtomicFile::create(&target).unwrap();
        f.write_all(b"new").unwrap();
        f.commit().unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
    }

    #[test]
    fn temporary_names_are_unique_and_listed_until_commit() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("b.csv");
        let a = AtomicFile::create(&target).unwrap();
        let b = AtomicFile::create(&target).unwrap();
        let temps: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(temps.len(), 2, "{temps:?}");
        assert_ne!(temps[0], temps[1]);
        for t in &temps {
            assert!(is_temp_name(t, "b.csv"), "{t}");
            assert!(crate::interrupt::listed().contains(&dir.path().join(t)));
        }
        a.commit().unwrap();
        drop(b);
        let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(left.len(), 1);
        assert!(
            !crate::interrupt::listed()
                .iter()
                .any(|p| p.starts_with(dir.path()))
        );
    }

    #[test]
    fn create_new_refuses_a_file_that_appeared() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("rig.json");
        let mut f = AtomicFile::create_new(&target).unwrap();
        f.write_all(b"mine").unwrap();
        std::fs::write(&target, b"theirs").unwrap();
        let e = f.commit().unwrap_err();
        assert!(matches!(e, FormatError::Exists { .. }), "{e}");
        assert_eq!(std::fs::read(&target).unwrap(), b"theirs");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[cfg(unix)]
    #[test]
    fn outputs_are_readable_as_the_umask_allows() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("report.json");
        write_atomic(&target, b"{}").unwrap();
        let plain = dir.path().join("plain");
        std::fs::write(&plain, b"{}").unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&target), mode(&plain));
    }

    #[test]
    fn a_missing_output_folder_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("no-such").join("b.csv");
        let e = AtomicFile::create(&target).unwrap_err().to_string();
        assert!(
            e.contains("output folder") && e.contains("does not exist"),
            "{e}"
        );
        assert!(!e.contains(".b.csv."), "no temporary name: {e}");
    }

    #[test]
    fn temporary_names_are_told_apart() {
        assert!(is_temp_name(".b.csv.a1B2c3.tmp", "b.csv"));
        assert!(!is_temp_name(".b.csv.partial.a1B2c3.tmp", "b.csv"));
        assert!(!is_temp_name(".b.csv.a1B2c.tmp", "b.csv"));
        assert!(!is_temp_name("b.csv.a1B2c3.tmp", "b.csv"));
        assert!(!is_temp_name(".b.csv.a1-2c3.tmp", "b.csv"));
    }
}
