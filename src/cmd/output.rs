//! What a command says of its outputs and names beside them: the output
//! plan's notes, a batch's problems file, and the room they need.

use std::path::{Path, PathBuf};

use formats::OutputPlan;

/// Print the notes of an output plan (a stale lock taken over).
pub fn print_notes(plan: &OutputPlan) {
    for note in plan.notes() {
        eprintln!("trinocular: note: {note}");
    }
}

/// `<stem>.problems.csv` beside the output `out` of a batch.
pub fn problems_path(out: &Path) -> PathBuf {
    formats::beside(out, "out", ".problems.csv")
}

/// Bytes free to an unprivileged writer on the file system that holds
/// `path` (or its nearest existing folder: an output folder is made later);
/// `None` where the platform does not say.
pub fn free_bytes(path: &Path) -> Option<u64> {
    let absolute = std::path::absolute(path).ok()?;
    let existing = absolute.ancestors().find(|p| p.exists())?;
    #[cfg(unix)]
    {
        let s = rustix::fs::statvfs(existing).ok()?;
        Some(s.f_bavail.saturating_mul(s.f_frsize))
    }
    #[cfg(not(unix))]
    {
        let _ = existing;
        None
    }
}

/// Refuses, before anything is written, an output of at least `needed`
/// bytes (`what` says what it is) where the file system holding `out` has
/// less free.
pub fn check_room(out: &Path, needed: u64, what: &str) -> anyhow::Result<()> {
    match free_bytes(out) {
        Some(free) if free < needed => anyhow::bail!(
            "{}: {what} need at least {:.2} GB, and {:.2} GB are free there",
            out.display(),
            needed as f64 / 1e9,
            free as f64 / 1e9
        ),
        _ => Ok(()),
    }
}
