//! The output plan of a command: every file and folder it will write,
//! declared and checked before anything is written, then written through the
//! plan only.
//!
//! The rules, the same for every command:
//! - an output is never written over one of the command's inputs: paths are
//!   compared canonically (through symbolic links) and by file identity
//!   (hard links), and a folder replaced as a whole must not hold an input —
//!   even with `--force`;
//! - an output that exists is replaced only with `--force` (or by the run
//!   that left it, when resuming); without it the run stops before writing,
//!   and a file that appears while the run works is not replaced either
//!   (no-clobber rename at commit);
//! - missing output folders are created — the `--out DIR` of a command that
//!   writes a folder, the folder of an output file — when the first file is
//!   written into them;
//! - a run that fails removes what it created ([`crate::created`]): the
//!   folders it made, the files and sets it put in place where none was, its
//!   lock; never a file or folder that existed before it;
//! - long batch writers hold the lock of their output folder
//!   ([`crate::OutputLock`]); taking over a dead run's lock removes the temporary
//!   files that run left beside the planned outputs;
//! - a folder written as one set (a report) is staged in a fresh temporary
//!   folder beside it and exchanged with the old one in one rename, so a
//!   failure leaves the old set whole and no file of an earlier set stands
//!   beside a new one.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use serde::Serialize;

pub use crate::atomic::folder_of;
use crate::atomic::{
    AtomicFile, TEMP_RANDOM, TEMP_SUFFIX, create_error, is_temp_name, sync_folder, temp_prefix,
    write_into,
};
use crate::interrupt::{Kind, Listed, create_listed};
use crate::lock::{Acquired, OutputLock};
use crate::{FormatError, Record, Result};

/// What a planned file is to the command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Role {
    /// A result: refused when it exists, unless forced or resuming.
    Result,
    /// State the command keeps between runs (the partial output of a
    /// resumable batch): replaced freely, never an input.
    State,
}

/// A path and what identifies the file it names.
#[derive(Debug, Clone)]
struct Identity {
    /// As given.
    path: PathBuf,
    /// Canonical path (for a missing file: its canonical folder joined with its name).
    canonical: Option<PathBuf>,
    /// Device and inode of an existing file.
    file: Option<(u64, u64)>,
}

impl Identity {
    fn of(path: &Path) -> Self {
        Self {
            path: path.to_path_buf(),
            canonical: std::fs::canonicalize(path).ok().or_else(|| to_be(path)),
            file: file_id(path),
        }
    }

    fn same(&self, other: &Self) -> bool {
        (self.canonical.is_some() && self.canonical == other.canonical)
            || (self.file.is_some() && self.file == other.file)
    }
}

/// The canonical path a missing `path` will have once its missing folders
/// are made: its longest existing head, canonical, then the rest of its
/// components (`..` taken lexically, as it is in folders without links).
fn to_be(path: &Path) -> Option<PathBuf> {
    use std::path::Component;
    let parts: Vec<Component> = path.components().collect();
    (0..parts.len()).rev().find_map(|split| {
        let head: PathBuf = parts[..split].iter().collect();
        let head = if split == 0 { PathBuf::from(".") } else { head };
        let mut base = std::fs::canonicalize(head).ok()?;
        for part in &parts[split..] {
            match part {
                Component::ParentDir => {
                    base.pop();
                }
                Component::Normal(name) => base.push(name),
                _ => {}
            }
        }
        Some(base)
    })
}

#[cfg(unix)]
fn file_id(path: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn file_id(_path: &Path) -> Option<(u64, u64)> {
    None
}

/// A folder written as one set, and the names a set may hold.
#[derive(Debug, Clone)]
struct Set {
    folder: PathBuf,
    names: &'static [&'static str],
}

/// Whether `name` matches `pattern` (one optional `*` for any run of characters).
fn matches(pattern: &str, name: &str) -> bool {
    match pattern.split_once('*') {
        Some((head, tail)) => {
            name.len() >= head.len() + tail.len() && name.starts_with(head) && name.ends_with(tail)
        }
        None => pattern == name,
    }
}

/// Every file and folder a command writes, checked before anything is written.
#[derive(Debug)]
pub struct OutputPlan {
    force: bool,
    resuming: bool,
    checked: bool,
    inputs: Vec<PathBuf>,
    files: BTreeMap<PathBuf, Role>,
    /// The files in the order planned (faults are reported in this order).
    order: Vec<PathBuf>,
    folders: BTreeSet<PathBuf>,
    sets: Vec<Set>,
    /// Outputs planned twice (two outputs of one name).
    twice: Vec<PathBuf>,
    lock: Option<OutputLock>,
    notes: Vec<String>,
}

impl OutputPlan {
    /// A plan; `force` lets existing outputs be replaced (`--force`).
    pub fn new(force: bool) -> Self {
        Self {
            force,
            resuming: false,
            checked: false,
            inputs: Vec::new(),
            files: BTreeMap::new(),
            order: Vec::new(),
            folders: BTreeSet::new(),
            sets: Vec::new(),
            twice: Vec::new(),
            lock: None,
            notes: Vec::new(),
        }
    }

    /// Whether existing outputs may be replaced (`--force`).
    pub fn force(&self) -> bool {
        self.force
    }

    /// An input of the command (a file or a folder): no output may be written over it.
    pub fn input(&mut self, path: impl AsRef<Path>) -> &mut Self {
        self.inputs.push(path.as_ref().to_path_buf());
        self
    }

    /// Inputs of the command.
    pub fn inputs<P: AsRef<Path>>(&mut self, paths: impl IntoIterator<Item = P>) -> &mut Self {
        for p in paths {
            self.input(p);
        }
        self
    }

    /// An output folder (`--out DIR`): a folder, never a file; created if
    /// missing when its first file is written.
    pub fn folder(&mut self, path: impl AsRef<Path>) -> &mut Self {
        self.folders.insert(path.as_ref().to_path_buf());
        self
    }

    /// An output file.
    pub fn file(&mut self, path: impl AsRef<Path>) -> &mut Self {
        self.plan_file(path.as_ref(), Role::Result)
    }

    fn plan_file(&mut self, path: &Path, role: Role) -> &mut Self {
        if self.files.insert(path.to_path_buf(), role).is_some() {
            self.twice.push(path.to_path_buf());
        } else {
            self.order.push(path.to_path_buf());
        }
        self
    }

    /// A file the command keeps between its runs (resume state): replaced
    /// whenever the command needs to, but never an input.
    pub fn state(&mut self, path: impl AsRef<Path>) -> &mut Self {
        self.plan_file(path.as_ref(), Role::State)
    }

    /// A folder written as one set ([`OutputPlan::stage`]): replaced as a
    /// whole, so with `--force` it may hold only files whose names match
    /// `names` (`*` for any run of characters) — anything else in it is
    /// refused, never deleted.
    pub fn set(&mut self, folder: impl AsRef<Path>, names: &'static [&'static str]) -> &mut Self {
        self.sets.push(Set {
            folder: folder.as_ref().to_path_buf(),
            names,
        });
        self
    }

    /// This run continues an interrupted one whose state the command has
    /// checked (same inputs and options): outputs that run may have left are
    /// replaced.
    pub fn resume(&mut self) {
        self.resuming = true;
    }

    /// What the plan did that a user should hear of (a stale lock taken over).
    pub fn notes(&self) -> &[String] {
        &self.notes
    }

    /// Lock the output folder `folder` for `command` ([`crate::OutputLock`]),
    /// making it first if missing. A lock left by a
    /// dead run is taken over (a note says so) and the temporary files that
    /// run left beside the planned outputs are removed: declare the outputs
    /// first. Held until the plan is dropped.
    pub fn lock(&mut self, folder: impl AsRef<Path>, command: &str) -> Result<()> {
        let folder = folder.as_ref();
        crate::created::make_folders(folder)?;
        let Acquired { lock, stale } = OutputLock::acquire(folder, command)?;
        self.lock = Some(lock);
        if let Some(holder) = stale {
            let removed = self.remove_stale_temps(folder)?;
            self.notes.push(format!(
                "{}: took over the lock of a run that is no longer running ({holder}){}",
                folder.display(),
                match removed {
                    0 => String::new(),
                    1 => "; removed the temporary file it left".into(),
                    n => format!("; removed the {n} temporary files it left"),
                }
            ));
        }
        Ok(())
    }

    /// Remove the temporary files of planned outputs under `folder`.
    fn remove_stale_temps(&self, folder: &Path) -> Result<usize> {
        let mut by_folder: BTreeMap<&Path, BTreeSet<String>> = BTreeMap::new();
        for path in self.files.keys() {
            if (path.starts_with(folder) || folder_of(path) == folder)
                && let Some(name) = path.file_name()
            {
                by_folder
                    .entry(folder_of(path))
                    .or_default()
                    .insert(name.to_string_lossy().into_owned());
            }
        }
        let mut removed = 0;
        for (dir, names) in by_folder {
            let Ok(entries) = std::fs::read_dir(dir) else {
                continue;
            };
            for entry in entries.flatten() {
                let name = entry.file_name().to_string_lossy().into_owned();
                // `.NAME.XXXXXX.tmp`: NAME is what lies between the first dot and the random part.
                let Some(target) = name
                    .len()
                    .checked_sub(TEMP_RANDOM + TEMP_SUFFIX.len() + 1)
                    .and_then(|end| name.get(1..end))
                else {
                    continue;
                };
                if names.contains(target) && is_temp_name(&name, target) {
                    let path = entry.path();
                    std::fs::remove_file(&path).map_err(|e| FormatError::io(&path, e))?;
                    removed += 1;
                }
            }
        }
        Ok(removed)
    }

    /// Check every planned output against the inputs and the files that
    /// exist; the first fault found is the error. Nothing is written (missing
    /// folders are made when their first file is written).
    pub fn check(&mut self) -> Result<()> {
        let inputs: Vec<Identity> = self.inputs.iter().map(|p| Identity::of(p)).collect();
        let replace = self.force || self.resuming;
        if let Some(path) = self.twice.first() {
            return Err(FormatError::file(
                path,
                "two outputs of this command would have this name; choose another --out",
            ));
        }
        for folder in &self.folders {
            crate::created::missing_folders(folder)?;
        }
        for path in &self.order {
            let role = self.files.get(path).copied().unwrap_or(Role::Result);
            let out = Identity::of(path);
            if let Some(input) = inputs.iter().find(|i| i.same(&out)) {
                return Err(FormatError::OverwritesInput {
                    output: path.clone(),
                    input: input.path.clone(),
                });
            }
            if path.is_dir() {
                return Err(FormatError::file(
                    path,
                    "is a folder; this output is a file, choose another --out",
                ));
            }
            if role == Role::Result && !replace && path.symlink_metadata().is_ok() {
                return Err(FormatError::Exists { path: path.clone() });
            }
            crate::created::missing_folders(folder_of(path))?;
        }
        for set in &self.sets {
            crate::created::missing_folders(&set.folder)?;
            self.check_set(set, &inputs)?;
        }
        self.checked = true;
        Ok(())
    }

    fn check_set(&self, set: &Set, inputs: &[Identity]) -> Result<()> {
        let folder = &set.folder;
        if let Some(canonical) = Identity::of(folder).canonical {
            for input in inputs {
                if input
                    .canonical
                    .as_ref()
                    .is_some_and(|c| c.starts_with(&canonical))
                {
                    return Err(FormatError::OverwritesInput {
                        output: folder.clone(),
                        input: input.path.clone(),
                    });
                }
            }
        }
        if !folder.exists() {
            return Ok(());
        }
        if !folder.is_dir() {
            return Err(FormatError::file(
                folder,
                "is a file, not a folder; choose another --out",
            ));
        }
        let entries = std::fs::read_dir(folder).map_err(|e| FormatError::io(folder, e))?;
        let mut any = false;
        for entry in entries {
            let entry = entry.map_err(|e| FormatError::io(folder, e))?;
            any = true;
            let name = entry.file_name().to_string_lossy().into_owned();
            let is_file = entry.file_type().is_ok_and(|t| t.is_file());
            if !is_file || !set.names.iter().any(|p| matches(p, &name)) {
                return Err(FormatError::file(
                    folder,
                    format!(
                        "holds {name}, which this command does not write; the folder is replaced \
                         as a whole, so choose another --out"
                    ),
                ));
            }
        }
        if any && !self.force {
            return Err(FormatError::Exists {
                path: folder.clone(),
            });
        }
        Ok(())
    }

    /// Start writing a planned output file.
    pub fn create(&self, path: &Path) -> Result<AtomicFile> {
        let role = self.planned(path)?;
        crate::created::make_folders(folder_of(path))?;
        if role == Role::State || self.force || self.resuming {
            AtomicFile::create(path)
        } else {
            AtomicFile::create_new(path)
        }
    }

    fn planned(&self, path: &Path) -> Result<Role> {
        if !self.checked {
            return Err(FormatError::file(
                path,
                "the output plan was not checked before writing (a bug)",
            ));
        }
        self.files
            .get(path)
            .copied()
            .ok_or_else(|| FormatError::file(path, "not in the command's output plan (a bug)"))
    }

    /// Write a planned output file.
    pub fn write_bytes(&self, path: &Path, bytes: &[u8]) -> Result<()> {
        write_into(self.create(path)?, bytes)
    }

    /// Write a planned output file as pretty JSON.
    pub fn write_json<T: Serialize>(&self, path: &Path, value: &T) -> Result<()> {
        write_into(self.create(path)?, &crate::json::to_bytes(path, value)?)
    }

    /// Write a planned output file as CSV (header from the first row).
    pub fn write_csv<'a, T: Serialize + 'a>(
        &self,
        path: &Path,
        records: impl IntoIterator<Item = &'a T>,
    ) -> Result<()> {
        crate::table::write_csv_into(self.create(path)?, records)
    }

    /// Write a planned output file of contract records (header even when empty).
    pub fn write_records<'a, T: Record + 'a>(
        &self,
        path: &Path,
        records: impl IntoIterator<Item = &'a T>,
    ) -> Result<()> {
        crate::table::write_records_into(self.create(path)?, records)
    }

    /// Remove a planned output that this run found stale (e.g. a
    /// `problems.csv` when there were no problems); only a file the plan may
    /// replace is removed.
    pub fn remove(&self, path: &Path) -> Result<()> {
        self.planned(path)?;
        match std::fs::remove_file(path) {
            Ok(()) => sync_folder(folder_of(path)),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
            Err(e) => Err(FormatError::io(path, e)),
        }
    }

    /// A fresh staging folder for the planned set `folder`: write the set
    /// into [`Stage::path`], then [`Stage::commit`].
    pub fn stage(&self, folder: &Path) -> Result<Stage> {
        if !self.checked || !self.sets.iter().any(|s| s.folder == folder) {
            return Err(FormatError::file(
                folder,
                "not a checked set of the command's output plan (a bug)",
            ));
        }
        let prefix = temp_prefix(folder)?;
        let parent = folder_of(folder);
        crate::created::make_folders(parent)?;
        let (temp, listed) = create_listed(Kind::Folder, || {
            let temp = crate::atomic::temp_builder(&prefix, true).tempdir_in(parent)?;
            let path = temp.path().to_path_buf();
            Ok((temp, path))
        })
        .map_err(|e| create_error(folder, parent, e))?;
        Ok(Stage {
            target: folder.to_path_buf(),
            temp,
            _listed: listed,
        })
    }
}

/// A set being written in its staging folder; dropped without commit, the
/// staging folder is removed.
#[derive(Debug)]
pub struct Stage {
    target: PathBuf,
    temp: tempfile::TempDir,
    _listed: Listed,
}

impl Stage {
    /// The staging folder: write the set's files here.
    pub fn path(&self) -> &Path {
        self.temp.path()
    }

    /// Put the set in place of the old one (if any) in one exchange, then
    /// remove the old set; a set where none was is recorded as the run's
    /// ([`crate::created`]).
    pub fn commit(self) -> Result<()> {
        let staged = self.temp.path();
        sync_folder(staged)?;
        let replaced =
            exchange(staged, &self.target).map_err(|e| FormatError::io(&self.target, e))?;
        sync_folder(folder_of(&self.target))?;
        if replaced {
            // The staging path now holds the old set.
            self.temp
                .close()
                .map_err(|e| FormatError::io(&self.target, e))
        } else {
            // Nothing left at the staging path to remove.
            let _ = self.temp.keep();
            crate::created::set(&self.target);
            Ok(())
        }
    }
}

/// Move `staged` to `target`; an existing `target` ends up at `staged`
/// (then `true`). On Linux one `renameat2(RENAME_EXCHANGE)`: a crash leaves
/// either set whole under `target`. Elsewhere (or where the file system
/// cannot exchange) the old set is moved aside first.
fn exchange(staged: &Path, target: &Path) -> std::io::Result<bool> {
    if !target.exists() {
        return std::fs::rename(staged, target).map(|()| false);
    }
    #[cfg(target_os = "linux")]
    {
        use rustix::fs::{CWD, RenameFlags, renameat_with};
        match renameat_with(CWD, staged, CWD, target, RenameFlags::EXCHANGE) {
            Ok(()) => return Ok(true),
            Err(e) if e == rustix::io::Errno::INVAL || e == rustix::io::Errno::NOSYS => {}
            Err(e) => return Err(e.into()),
        }
    }
    let mut aside = staged.as_os_str().to_owned();
    aside.push(".old");
    let aside = PathBuf::from(aside);
    std::fs::rename(target, &aside)?;
    std::fs::rename(staged, target)?;
    std::fs::rename(&aside, staged).map(|()| true)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    #[test]
    fn patterns() {
        assert!(matches("positioning_*.csv", "positioning_X.csv"));
        assert!(matches("report.json", "report.json"));
        assert!(!matches("positioning_*.csv", "positioning.csv"));
        assert!(!matches("report.json", "report.json.bak"));
    }

    #[test]
    fn an_existing_output_needs_force() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("b.csv");
        std::fs::write(&out, "old").unwrap();
        let mut plan = OutputPlan::new(false);
        plan.file(&out);
        let e = plan.check().unwrap_err();
        assert!(matches!(e, FormatError::Exists { .. }), "{e}");
        let mut plan = OutputPlan::new(true);
        plan.file(&out);
        plan.check().unwrap();
        plan.write_bytes(&out, b"new").unwrap();
        assert_eq!(std::fs::read(&out).unwrap(), b"new");
    }

    #[cfg(unix)]
    #[test]
    fn an_input_is_never_an_output_also_through_links() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let image = d.join("z.tif");
        std::fs::write(&image, "pixels").unwrap();
        std::os::unix::fs::symlink(&image, d.join("soft.tif")).unwrap();
        std::fs::hard_link(&image, d.join("hard.tif")).unwrap();
        std::fs::create_dir(d.join("sub")).unwrap();
        for out in [
            image.clone(),
            d.join("soft.tif"),
            d.join("hard.tif"),
            d.join("sub").join("..").join("z.tif"),
        ] {
            let mut plan = OutputPlan::new(true);
            plan.input(&image).file(&out);
            let e = plan.check().unwrap_err();
            assert!(
                matches!(e, FormatError::OverwritesInput { .. }),
                "{out:?}: {e}"
            );
        }
        assert_eq!(std::fs::read(&image).unwrap(), b"pixels");
    }

    #[test]
    fn writes_go_through_the_checked_plan_only() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("a.csv");
        let mut plan = OutputPlan::new(false);
        plan.file(&out);
        assert!(plan.write_bytes(&out, b"x").is_err(), "not checked yet");
        plan.check().unwrap();
        assert!(
            plan.write_bytes(&dir.path().join("other.csv"), b"x")
                .is_err()
        );
        plan.write_bytes(&out, b"x").unwrap();
    }

    #[test]
    fn missing_output_folders_are_made_with_their_first_file() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("nope").join("deeper").join("b.csv");
        let mut plan = OutputPlan::new(false);
        plan.file(&out);
        plan.check().unwrap();
        assert!(
            !dir.path().join("nope").exists(),
            "made with its first file"
        );
        plan.write_bytes(&out, b"x").unwrap();
        assert!(out.is_file());
        // A file where a folder is needed is named.
        std::fs::write(dir.path().join("f"), "mine").unwrap();
        let mut plan = OutputPlan::new(true);
        plan.file(dir.path().join("f").join("b.csv"));
        let e = plan.check().unwrap_err().to_string();
        assert!(e.contains("is a file, not a folder"), "{e}");
    }

    #[test]
    fn an_output_through_a_missing_folder_is_still_not_an_input() {
        let dir = tempfile::tempdir().unwrap();
        let image = dir.path().join("z.tif");
        std::fs::write(&image, "pixels").unwrap();
        let mut plan = OutputPlan::new(true);
        plan.input(&image)
            .file(dir.path().join("nope").join("..").join("z.tif"));
        let e = plan.check().unwrap_err();
        assert!(matches!(e, FormatError::OverwritesInput { .. }), "{e}");
    }

    #[test]
    fn a_set_replaces_the_old_one_whole() {
        const NAMES: &[&str] = &["report.json", "table_*.csv"];
        let dir = tempfile::tempdir().unwrap();
        let report = dir.path().join("report");
        let write = |files: &[&str], force: bool| -> Result<()> {
            let mut plan = OutputPlan::new(force);
            plan.set(&report, NAMES);
            plan.check()?;
            let stage = plan.stage(&report)?;
            for f in files {
                std::fs::write(stage.path().join(f), f).unwrap();
            }
            stage.commit()
        };
        write(&["report.json", "table_X.csv", "table_Y.csv"], false).unwrap();
        let e = write(&["report.json"], false).unwrap_err();
        assert!(matches!(e, FormatError::Exists { .. }), "{e}");
        write(&["report.json", "table_X.csv"], true).unwrap();
        let mut names: Vec<String> = std::fs::read_dir(&report)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(
            names,
            ["report.json", "table_X.csv"],
            "no stale table_Y.csv"
        );
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            1,
            "no staging left"
        );

        // A file the set does not write is never deleted, even with --force.
        std::fs::write(report.join("notes.txt"), "mine").unwrap();
        let e = write(&["report.json"], true).unwrap_err().to_string();
        assert!(e.contains("holds notes.txt"), "{e}");
        assert!(report.join("notes.txt").exists());
        // Nor is a set folder that holds an input.
        let mut plan = OutputPlan::new(true);
        plan.input(report.join("notes.txt")).set(&report, NAMES);
        let e = plan.check().unwrap_err();
        assert!(matches!(e, FormatError::OverwritesInput { .. }), "{e}");
    }

    #[test]
    fn a_dropped_stage_leaves_the_old_set() {
        let dir = tempfile::tempdir().unwrap();
        let report = dir.path().join("r");
        std::fs::create_dir(&report).unwrap();
        std::fs::write(report.join("report.json"), "old").unwrap();
        let mut plan = OutputPlan::new(true);
        plan.set(&report, &["report.json"]);
        plan.check().unwrap();
        {
            let stage = plan.stage(&report).unwrap();
            std::fs::write(stage.path().join("report.json"), "half").unwrap();
        }
        assert_eq!(std::fs::read(report.join("report.json")).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn a_dead_runs_temporary_files_go_with_its_lock() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::write(
            d.join(crate::lock::LOCK_FILE),
            "pid 999999, trinocular extract\n",
        )
        .unwrap();
        std::fs::write(d.join(".b.csv.Ab12Cd.tmp"), "half").unwrap();
        std::fs::write(d.join(".other.csv.Ab12Cd.tmp"), "not ours").unwrap();
        let mut plan = OutputPlan::new(false);
        plan.file(d.join("b.csv")).file(d.join("problems.csv"));
        plan.lock(d, "extract").unwrap();
        assert_eq!(plan.notes().len(), 1);
        assert!(plan.notes()[0].contains("pid 999999"), "{:?}", plan.notes());
        assert!(!d.join(".b.csv.Ab12Cd.tmp").exists());
        assert!(d.join(".other.csv.Ab12Cd.tmp").exists());
        plan.check().unwrap();
        drop(plan);
        assert!(!d.join(crate::lock::LOCK_FILE).exists());
    }
}
